//! THE table of MaterialX atoms: nodedef (by its node category) → lowering onto existing IR
//! ops, and the geometric property streams.
//!
//! Every stdlib nodedef that the libraries do not implement as a nodegraph is looked up
//! here by its `node` (one lowering serves all of a node's type variants: `ND_add_color3`,
//! `ND_add_color3FA`, … — a float operand is broadcast). This module owns what each atom
//! computes (the formulas of the MaterialX specification); it must not parse documents or
//! resolve nodedefs. The lowerings themselves are in [`super::atoms_lower`].

use super::atoms_flake as flake;
use super::atoms_geom as geom;
use super::atoms_lower as l;
use super::atoms_matrix as mx;
use super::atoms_pbr as pbr;
use super::atoms_tiling as tl;
use super::document::NodeDefElem;
use crate::ir::Stream;
use crate::nodes::LowerFn;

/// One row: node category, the inputs the lowering reads (space-separated), the lowering,
/// and whether its matrix33/matrix44 variants are lowered too.
struct Atom {
    node: &'static str,
    ports: &'static str,
    lower: LowerFn,
    matrix: bool,
}

const fn a(node: &'static str, ports: &'static str, lower: LowerFn) -> Atom {
    Atom {
        node,
        ports,
        lower,
        matrix: false,
    }
}

const fn m(node: &'static str, ports: &'static str, lower: LowerFn) -> Atom {
    Atom {
        node,
        ports,
        lower,
        matrix: true,
    }
}

/// The table.
const ATOMS: &[Atom] = &[
    // constants and pass-through
    m("constant", "value", l::constant),
    m("dot", "in", l::dot),
    // math
    m("add", "in1 in2", l::add),
    m("subtract", "in1 in2", l::subtract),
    m("multiply", "in1 in2", l::multiply),
    m("divide", "in1 in2", l::divide),
    a("modulo", "in1 in2", l::modulo),
    a("fract", "in", l::fract),
    a("invert", "in amount", l::invert),
    a("absval", "in", l::absval),
    a("sign", "in", l::sign),
    a("floor", "in", l::floor),
    a("ceil", "in", l::ceil),
    a("round", "in", l::round),
    a("power", "in1 in2", l::power),
    a("sin", "in", l::sin),
    a("cos", "in", l::cos),
    a("tan", "in", l::tan),
    a("asin", "in", l::asin),
    a("acos", "in", l::acos),
    a("atan2", "iny inx", l::atan2),
    a("sqrt", "in", l::sqrt),
    a("ln", "in", l::ln),
    a("exp", "in", l::exp),
    a("clamp", "in low high", l::clamp),
    a("remap", "in inlow inhigh outlow outhigh", l::remap),
    a("smoothstep", "in low high", l::smoothstep),
    a("min", "in1 in2", l::min),
    a("max", "in1 in2", l::max),
    a("normalize", "in", l::normalize),
    a("magnitude", "in", l::magnitude),
    a("distance", "in1 in2", l::distance),
    a("dotproduct", "in1 in2", l::dotproduct),
    a("crossproduct", "in1 in2", l::crossproduct),
    a(
        "normalmap",
        "in scale normal tangent bitangent",
        l::normalmap,
    ),
    a("transformpoint", "in fromspace tospace", l::transformpoint),
    a(
        "transformvector",
        "in fromspace tospace",
        l::transformvector,
    ),
    a(
        "transformnormal",
        "in fromspace tospace",
        l::transformnormal,
    ),
    m("transformmatrix", "in mat", mx::transformmatrix),
    m("transpose", "in", mx::transpose),
    m("determinant", "in", mx::determinant),
    m("invertmatrix", "in", mx::invertmatrix),
    m("creatematrix", "in1 in2 in3", mx::creatematrix),
    a("rotate2d", "in amount", l::rotate2d),
    a("rotate3d", "in amount axis", l::rotate3d),
    a("mix", "fg bg mix", l::mix),
    // compositing
    a("plus", "fg bg mix", l::plus),
    a("minus", "fg bg mix", l::minus),
    a("difference", "fg bg mix", l::difference),
    a("screen", "fg bg mix", l::screen),
    a("burn", "fg bg mix", l::burn),
    a("dodge", "fg bg mix", l::dodge),
    a("inside", "in mask", l::inside),
    a("outside", "in mask", l::outside),
    a("premult", "in", l::premult),
    a("unpremult", "in", l::unpremult),
    a("over", "fg bg mix", l::over),
    a("in", "fg bg mix", l::in_),
    a("mask", "fg bg mix", l::mask),
    a("matte", "fg bg mix", l::matte),
    a("out", "fg bg mix", l::out),
    a("disjointover", "fg bg mix", l::disjointover),
    // color
    a("luminance", "in lumacoeffs", l::luminance),
    a("rgbtohsv", "in", l::rgbtohsv),
    a("hsvtorgb", "in", l::hsvtorgb),
    // logic and conditionals
    m("ifgreater", "value1 value2", l::ifgreater),
    m("ifgreatereq", "value1 value2", l::ifgreatereq),
    m("ifequal", "value1 value2", l::ifequal),
    a("and", "in1 in2", l::and),
    a("or", "in1 in2", l::or),
    a("not", "in", l::not),
    // channels and conversion
    a("convert", "in", l::convert),
    a("combine2", "in1 in2", l::combine),
    a("combine3", "in1 in2 in3", l::combine),
    a("combine4", "in1 in2 in3 in4", l::combine),
    m("extract", "in index", l::extract),
    // geometric
    a("position", "space", l::position),
    a("normal", "space", l::normal),
    a("tangent", "space", l::tangent),
    a("bitangent", "space", l::bitangent),
    a("texcoord", "", l::texcoord),
    a("time", "", l::time),
    a("geomcolor", "index", geom::geomcolor),
    a("geompropvalue", "geomprop default", geom::geompropvalue),
    // procedural
    a("ramplr", "valuel valuer texcoord", l::ramplr),
    a("ramptb", "valuet valueb texcoord", l::ramptb),
    a("splitlr", "valuel valuer center texcoord", l::splitlr),
    a("splittb", "valuet valueb center texcoord", l::splittb),
    a("noise2d", "amplitude pivot texcoord", l::noise2d),
    a("noise3d", "amplitude pivot position", l::noise3d),
    a(
        "fractal2d",
        "amplitude octaves lacunarity diminish texcoord",
        l::fractal2d,
    ),
    a(
        "fractal3d",
        "amplitude octaves lacunarity diminish position",
        l::fractal3d,
    ),
    a("cellnoise2d", "texcoord", l::cellnoise2d),
    a("cellnoise3d", "position", l::cellnoise3d),
    a("worleynoise2d", "texcoord jitter style", l::worleynoise2d),
    a("worleynoise3d", "position jitter style", l::worleynoise3d),
    a(
        "flake2d",
        "size roughness coverage texcoord normal tangent bitangent",
        flake::flake2d,
    ),
    a(
        "flake3d",
        "size roughness coverage position normal tangent bitangent",
        flake::flake3d,
    ),
    // texture
    a("image", "file default texcoord", l::image),
    a(
        "hextiledimage",
        "file default texcoord tiling rotation rotationrange scale scalerange offset \
         offsetrange falloff falloffcontrast lumacoeffs",
        tl::hextiledimage,
    ),
    a(
        "hextilednormalmap",
        "file texcoord tiling rotation rotationrange scale scalerange offset offsetrange \
         falloff strength flip_g normal tangent bitangent",
        tl::hextilednormalmap,
    ),
    // derivatives
    a("heighttonormal", "in scale texcoord", tl::heighttonormal),
    // pbrlib values
    a(
        "roughness_anisotropy",
        "roughness anisotropy",
        pbr::roughness_anisotropy,
    ),
    a("roughness_dual", "roughness", pbr::roughness_dual),
    a("artistic_ior", "reflectivity edge_color", pbr::artistic_ior),
    a("blackbody", "temperature", pbr::blackbody),
];

/// Whether a nodedef makes a closure (its first output is a closure or shader type).
fn is_closure_def(nd: &NodeDefElem) -> bool {
    nd.outputs
        .first()
        .is_some_and(|o| super::value::CLOSURE_TYPES.contains(&o.ty.as_str()))
}

fn has_matrix(nd: &NodeDefElem) -> bool {
    nd.inputs
        .iter()
        .chain(&nd.outputs)
        .any(|p| p.ty == "matrix44" || p.ty == "matrix33")
}

/// The lowering of an atom nodedef, if the table has one for its node and types and the
/// nodedef has every input the lowering reads (a document may declare its own nodedef of a
/// known node with other inputs: it is not an atom then).
pub fn lowering(nd: &NodeDefElem) -> Option<LowerFn> {
    if is_closure_def(nd) {
        return super::atoms_closure::lowering(&nd.node);
    }
    let row = ATOMS.iter().find(|r| r.node == nd.node)?;
    let has = |p: &str| nd.inputs.iter().any(|i| i.name == p);
    let ports_ok = row.ports.split_whitespace().all(has);
    (ports_ok && (row.matrix || !has_matrix(nd))).then_some(row.lower)
}

/// The node categories folded into their readers ([`super::strings`]) when their output is a string or a filename.
pub const FOLDED: [&str; 3] = ["constant", "dot", "geompropvalueuniform"];

/// Whether a nodedef is a compile-time string node of [`FOLDED`].
pub fn is_folded(nd: &NodeDefElem) -> bool {
    FOLDED.contains(&nd.node.as_str()) && nd.outputs.len() == 1 && is_string(&nd.outputs[0].ty)
}

/// Whether a MaterialX type is a string type (`string`, `filename`).
pub fn is_string(ty: &str) -> bool {
    matches!(ty, "string" | "filename")
}

/// Why a nodedef with neither a nodegraph nor a lowering is unsupported (for coverage).
pub fn missing_reason(nd: &NodeDefElem) -> &'static str {
    if is_closure_def(nd) {
        return super::atoms_closure::missing_reason(&nd.node);
    }
    if ATOMS.iter().any(|r| r.node == nd.node) {
        if nd
            .outputs
            .iter()
            .any(|o| o.ty == "string" || o.ty == "filename")
        {
            "a string output never reaches the IR (strings are uniform inputs only)"
        } else if has_matrix(nd) {
            "this node's matrix variants have no lowering"
        } else {
            "a port type has no IR type yet"
        }
    } else {
        match nd.node.as_str() {
            "frame" => "no frame number in the shading context yet",
            _ => "no lowering in the atom table yet",
        }
    }
}

/// The stream a `defaultgeomprop` names (world space: object-space variants read the world
/// stream, exact where object and world coincide, as on `shade`'s plane).
pub fn geomprop_stream(name: &str) -> Option<Stream> {
    Some(match name {
        "UV0" => Stream::Uv,
        "Pobject" | "Pworld" => Stream::P,
        "Nobject" | "Nworld" => Stream::N,
        "Tobject" | "Tworld" => Stream::DPdu,
        "Bobject" | "Bworld" => Stream::DPdv,
        _ => return None,
    })
}

/// The atom nodedef that reads a `defaultgeomprop` stream, with its `space` input, for a
/// nodegraph input left unset.
pub fn geomprop_node(name: &str) -> Option<(&'static str, Option<&'static str>)> {
    Some(match name {
        "UV0" => ("ND_texcoord_vector2", None),
        "Pobject" => ("ND_position_vector3", Some("object")),
        "Pworld" => ("ND_position_vector3", Some("world")),
        "Nobject" => ("ND_normal_vector3", Some("object")),
        "Nworld" => ("ND_normal_vector3", Some("world")),
        "Tobject" => ("ND_tangent_vector3", Some("object")),
        "Tworld" => ("ND_tangent_vector3", Some("world")),
        "Bobject" => ("ND_bitangent_vector3", Some("object")),
        "Bworld" => ("ND_bitangent_vector3", Some("world")),
        _ => return None,
    })
}
