//! THE table of MaterialX atoms: nodedef (by its node category) → lowering onto existing IR
//! ops, and the geometric property streams.
//!
//! Every stdlib nodedef that the libraries do not implement as a nodegraph is looked up
//! here by its `node` (one lowering serves all of a node's type variants: `ND_add_color3`,
//! `ND_add_color3FA`, … — a float operand is broadcast). This module owns what each atom
//! computes (the formulas of the MaterialX specification); it must not parse documents or
//! resolve nodedefs. The lowerings themselves are in [`super::atoms_lower`].

use super::atoms_lower as l;
use super::document::NodeDefElem;
use crate::ir::Stream;
use crate::nodes::LowerFn;

/// One row: node category, lowering, and whether its matrix44 variants are lowered too.
struct Atom {
    node: &'static str,
    lower: LowerFn,
    matrix: bool,
}

const fn a(node: &'static str, lower: LowerFn) -> Atom {
    Atom {
        node,
        lower,
        matrix: false,
    }
}

const fn m(node: &'static str, lower: LowerFn) -> Atom {
    Atom {
        node,
        lower,
        matrix: true,
    }
}

/// The table.
const ATOMS: &[Atom] = &[
    // constants and pass-through
    m("constant", l::constant),
    m("dot", l::dot),
    // math
    a("add", l::add),
    a("subtract", l::subtract),
    a("multiply", l::multiply),
    a("divide", l::divide),
    a("modulo", l::modulo),
    a("fract", l::fract),
    a("invert", l::invert),
    a("absval", l::absval),
    a("sign", l::sign),
    a("floor", l::floor),
    a("ceil", l::ceil),
    a("round", l::round),
    a("power", l::power),
    a("sin", l::sin),
    a("cos", l::cos),
    a("tan", l::tan),
    a("asin", l::asin),
    a("acos", l::acos),
    a("atan2", l::atan2),
    a("sqrt", l::sqrt),
    a("ln", l::ln),
    a("exp", l::exp),
    a("clamp", l::clamp),
    a("min", l::min),
    a("max", l::max),
    a("normalize", l::normalize),
    a("magnitude", l::magnitude),
    a("distance", l::distance),
    a("dotproduct", l::dotproduct),
    a("crossproduct", l::crossproduct),
    a("transformpoint", l::transformpoint),
    a("transformvector", l::transformvector),
    a("transformnormal", l::transformnormal),
    m("transformmatrix", l::transformmatrix),
    a("rotate2d", l::rotate2d),
    a("rotate3d", l::rotate3d),
    a("mix", l::mix),
    // compositing
    a("plus", l::plus),
    a("minus", l::minus),
    a("difference", l::difference),
    a("screen", l::screen),
    a("burn", l::burn),
    a("dodge", l::dodge),
    a("inside", l::inside),
    a("outside", l::outside),
    // color
    a("luminance", l::luminance),
    a("rgbtohsv", l::rgbtohsv),
    a("hsvtorgb", l::hsvtorgb),
    // logic and conditionals
    m("ifgreater", l::ifgreater),
    m("ifgreatereq", l::ifgreatereq),
    m("ifequal", l::ifequal),
    a("and", l::and),
    a("or", l::or),
    a("not", l::not),
    // channels and conversion
    a("convert", l::convert),
    a("combine2", l::combine),
    a("combine3", l::combine),
    a("extract", l::extract),
    // geometric
    a("position", l::position),
    a("normal", l::normal),
    a("tangent", l::tangent),
    a("bitangent", l::bitangent),
    a("texcoord", l::texcoord),
    a("time", l::time),
    // procedural
    a("ramplr", l::ramplr),
    a("ramptb", l::ramptb),
    a("splitlr", l::splitlr),
    a("splittb", l::splittb),
    a("noise2d", l::noise2d),
    a("noise3d", l::noise3d),
    a("fractal2d", l::fractal2d),
    a("fractal3d", l::fractal3d),
    a("cellnoise2d", l::cellnoise2d),
    a("cellnoise3d", l::cellnoise3d),
    // texture
    a("image", l::image),
];

fn has_matrix(nd: &NodeDefElem) -> bool {
    nd.inputs
        .iter()
        .chain(&nd.outputs)
        .any(|p| p.ty == "matrix44" || p.ty == "matrix33")
}

/// The lowering of an atom nodedef, if the table has one for its node and types.
pub fn lowering(nd: &NodeDefElem) -> Option<LowerFn> {
    let row = ATOMS.iter().find(|r| r.node == nd.node)?;
    (row.matrix || !has_matrix(nd)).then_some(row.lower)
}

/// Why a nodedef with neither a nodegraph nor a lowering is unsupported (for coverage).
pub fn missing_reason(nd: &NodeDefElem) -> &'static str {
    if ATOMS.iter().any(|r| r.node == nd.node) {
        if has_matrix(nd) {
            "matrix arithmetic other than transforms has no IR op yet"
        } else {
            "a port type has no IR type yet"
        }
    } else {
        match nd.node.as_str() {
            "geomcolor" | "geompropvalue" | "geompropvalueuniform" => {
                "no per-vertex attribute streams in the shading context yet"
            }
            "frame" => "no frame number in the shading context yet",
            "worleynoise2d" | "worleynoise3d" | "flake2d" | "flake3d" => {
                "no Worley/flake noise intrinsic yet"
            }
            "hextiledimage" | "hextilednormalmap" | "heighttonormal" | "normalmap" => {
                "needs texture derivatives or tangent frames (issue 11)"
            }
            "transpose" | "determinant" | "invertmatrix" | "creatematrix" => {
                "matrix operations have no IR op yet"
            }
            "premult" | "unpremult" | "disjointover" | "in" | "mask" | "matte" | "out" | "over"
            | "combine4" => "color4/vector4 have no IR type yet",
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
