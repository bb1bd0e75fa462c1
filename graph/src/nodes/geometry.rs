//! Standard nodes: geometry.
//!
//! Reading the fragment's implicit streams (`samplerInfo`), placing texture coordinates
//! (`place2d`) and transforming points by a matrix (`pointMatrixMult`). Streams are stored
//! in world space; a node that reads them in another space gets the transform inserted by
//! [`Builder::stream_in`].

use super::{LowVal, LowerFn, NodeDef, NodeInputs, NodeLibrary, OutDef, PortDef, port};
use crate::ir::{BinOp, Builder, Space, Stream, UnOp};
use crate::types::{ConstValue, Type};

fn node(
    name: &'static str,
    doc: &'static str,
    inputs: Vec<PortDef>,
    outputs: Vec<OutDef>,
    lower: LowerFn,
) -> NodeDef {
    NodeDef::shading("geometry", name, doc, &[], inputs, outputs, lower)
}

/// Registers the geometry nodes.
pub fn register(lib: &mut NodeLibrary) {
    lib.add(node(
        "samplerInfo",
        "The fragment's geometry (Maya `samplerInfo`), every vector in the space chosen by \
         `space`: `P` the shading point; `N` and `Ng` the shading and geometric normals, unit \
         length (in world space as the renderer supplies them, unit by contract; in camera \
         and object space renormalized after the transform; a zero normal stays zero); `I` the normalized incident direction, eye → P (zero if the stream is \
         zero); `uv` the surface parameters (no space); `dPdu`, `dPdv` the surface \
         derivatives, transformed as vectors and not normalized. `facingRatio = max(0, \
         dot(N, −normalize(I)))` is computed from the world-space streams whatever `space` \
         is (a cosine: 1 facing the eye, 0 at grazing angles and for back-facing or zero \
         normals).",
        vec![port::space(
            "space",
            "world",
            "The space the vectors are returned in.",
        )],
        vec![
            port::out("P", Type::Vec3, "Shading point."),
            port::out("N", Type::Vec3, "Unit shading normal."),
            port::out("Ng", Type::Vec3, "Unit geometric normal."),
            port::out("I", Type::Vec3, "Unit incident direction, eye → P."),
            port::out("uv", Type::Vec2, "Surface parameters."),
            port::out("dPdu", Type::Vec3, "∂P/∂u."),
            port::out("dPdv", Type::Vec3, "∂P/∂v."),
            port::out(
                "facingRatio",
                Type::Float,
                "Cosine between the normal and the direction to the eye, ≥ 0.",
            ),
        ],
        lower_sampler_info,
    ));
    lib.add(node(
        "place2d",
        "Texture placement (Maya `place2dTexture`, without wrapping, which the texture \
         does): first rotate `uvCoord` by `rotateUV` degrees counterclockwise about (0.5, \
         0.5): `d = uv − 0.5`, `r = (cos θ·d.u − sin θ·d.v, sin θ·d.u + cos θ·d.v) + 0.5`; \
         then `outUV = r · (repeatU, repeatV) + (offsetU, offsetV)`. With `rotateUV = 0` \
         the rotation is skipped exactly (an `If` region), so the default placement is the \
         identity.",
        vec![
            port::stream(
                "uvCoord",
                Type::Vec2,
                Stream::Uv,
                "The coordinates to place.",
            ),
            port::float("repeatU", 1.0, "Scale of u."),
            port::float("repeatV", 1.0, "Scale of v."),
            port::float("offsetU", 0.0, "Added to u after scaling."),
            port::float("offsetV", 0.0, "Added to v after scaling."),
            port::float(
                "rotateUV",
                0.0,
                "Rotation about (0.5, 0.5) in degrees, counterclockwise, applied first.",
            ),
        ],
        vec![port::out("outUV", Type::Vec2, "The placed coordinates.")],
        lower_place2d,
    ));
    lib.add(node(
        "pointMatrixMult",
        "Maya `pointMatrixMult`: transforms `inPoint` by `inMatrix` (row-major, points are \
         column vectors): `output = M·(p, 1)` (with translation), or `M·(p, 0)` (no \
         translation) when `vectorMultiply` is true. The matrix's bottom row is ignored \
         (affine transforms, no perspective divide). Note that Maya itself multiplies row \
         vectors (`p·M`): a Maya matrix must be transposed.",
        vec![
            port::input(
                "inMatrix",
                Type::Matrix44,
                ConstValue::identity(),
                "The matrix.",
            ),
            port::vec3("inPoint", [0.0; 3], "The point or vector."),
            port::boolean(
                "vectorMultiply",
                false,
                "Transform as a vector (no translation).",
            ),
        ],
        vec![port::out("output", Type::Vec3, "The transformed point.")],
        lower_point_matrix_mult,
    ));
}

fn lower_sampler_info(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let name = n.string("space");
    let space = Space::from_name(name)
        .ok_or_else(|| format!("space `{name}` is not one of world, camera, object"))?;
    let p = b.stream_in(Stream::P, space);
    let unit = |b: &mut Builder, s: Stream| {
        let v = b.stream_in(s, space);
        if space == Space::World {
            v
        } else {
            b.normalize(v)
        }
    };
    let nn = unit(b, Stream::N);
    let ng = unit(b, Stream::Ng);
    let i_raw = b.stream_in(Stream::I, space);
    let i = b.normalize(i_raw);
    let uv = b.stream(Stream::Uv);
    let dpdu = b.stream_in(Stream::DPdu, space);
    let dpdv = b.stream_in(Stream::DPdv, space);
    let (n_world, i_world) = if space == Space::World {
        (nn, i)
    } else {
        let n_world = b.stream(Stream::N);
        let i_world = b.stream(Stream::I);
        (n_world, b.normalize(i_world))
    };
    let to_eye = b.unary(UnOp::Neg, i_world);
    let cos = b.dot(n_world, to_eye);
    let zero = b.float(0.0);
    let facing = b.max(cos, zero);
    Ok([p, nn, ng, i, uv, dpdu, dpdv, facing]
        .into_iter()
        .map(LowVal::plain)
        .collect())
}

fn lower_place2d(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let uv = n.get("uvCoord");
    let deg = n.get("rotateUV");
    let zero = b.float(0.0);
    let rotating = b.binary(BinOp::Ne, deg, zero);
    // An `if` region: unrotated uv costs nothing, and derivatives flow through regions
    // (`Builder::derivs`) to filtered lookups downstream.
    let rotated = b.if_(
        rotating,
        |b| {
            let rad_per_deg = b.float(std::f64::consts::PI / 180.0);
            let theta = b.mul(deg, rad_per_deg);
            let (c, s) = (b.unary(UnOp::Cos, theta), b.unary(UnOp::Sin, theta));
            let half = b.float(0.5);
            let u = b.extract(uv, 0);
            let v = b.extract(uv, 1);
            let du = b.sub(u, half);
            let dv = b.sub(v, half);
            let (cu, sv) = (b.mul(c, du), b.mul(s, dv));
            let (su, cv) = (b.mul(s, du), b.mul(c, dv));
            let ru = b.sub(cu, sv);
            let rv = b.add(su, cv);
            let ru = b.add(ru, half);
            let rv = b.add(rv, half);
            vec![b.construct(Type::Vec2, &[ru, rv])]
        },
        |_| vec![uv],
    )[0];
    let repeat = b.construct(Type::Vec2, &[n.get("repeatU"), n.get("repeatV")]);
    let offset = b.construct(Type::Vec2, &[n.get("offsetU"), n.get("offsetV")]);
    let scaled = b.mul(rotated, repeat);
    Ok(vec![LowVal::plain(b.add(scaled, offset))])
}

fn lower_point_matrix_mult(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let (m, p) = (n.get("inMatrix"), n.get("inPoint"));
    let r = b.if_(
        n.get("vectorMultiply"),
        |b| vec![b.binary(BinOp::MulVector, m, p)],
        |b| vec![b.binary(BinOp::MulPoint, m, p)],
    );
    Ok(vec![LowVal::plain(r[0])])
}
