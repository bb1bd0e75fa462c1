//! Standard nodes: structure.
//!
//! Nodes that move values around rather than compute with them: splitting and merging
//! vectors, constants of every IR type, and choosing between inputs (`switch`,
//! `condition`). Choices are lowered to structured `If` regions, so a constant selector or
//! condition lets the optimizer's dead-branch pass drop the arms that are not taken.
//!
//! There is no `constantString`: strings are uniform-only and never reach the IR (a string
//! port is read by its lowering at compile time), so a node that outputs a string cannot be
//! lowered.

use super::{
    FLOAT_TYPES, LowVal, LowerFn, NodeDef, NodeInputs, NodeLibrary, OutDef, PortDef, port,
};
use crate::ir::{BinOp, Builder, Value};
use crate::types::{ConstValue, Type};

fn node(
    name: &'static str,
    doc: &'static str,
    generic: &'static [Type],
    inputs: Vec<PortDef>,
    outputs: Vec<OutDef>,
    lower: LowerFn,
) -> NodeDef {
    NodeDef::shading("structure", name, doc, generic, inputs, outputs, lower)
}

/// The constant nodes: (name, type, default, doc).
fn constants() -> Vec<(&'static str, Type, ConstValue, &'static str)> {
    vec![
        (
            "constantBool",
            Type::Bool,
            ConstValue::Bool(false),
            "A bool constant (or a bool parameter under class compilation): `out = value`.",
        ),
        (
            "constantInt",
            Type::Int,
            ConstValue::Int(0),
            "An int constant: `out = value`.",
        ),
        (
            "constantFloat",
            Type::Float,
            ConstValue::Float(0.0),
            "A float constant: `out = value`. Non-finite literals pass through unchanged (a \
             material output of one is zeroed and counted by the output guard).",
        ),
        (
            "constantVec2",
            Type::Vec2,
            ConstValue::Vec2([0.0; 2]),
            "A vec2 constant: `out = value`.",
        ),
        (
            "constantVec3",
            Type::Vec3,
            ConstValue::Vec3([0.0; 3]),
            "A vec3 constant: `out = value`.",
        ),
        (
            "constantColor",
            Type::Color,
            ConstValue::Color([0.0; 3]),
            "A color constant: `out = value`.",
        ),
        (
            "constantMatrix",
            Type::Matrix44,
            ConstValue::identity(),
            "A matrix44 constant (row-major, points are column vectors: `M·p`): `out = \
             value`. Feed it to a node that takes a matrix (`pointMatrixMult`).",
        ),
    ]
}

/// Registers the structure nodes.
pub fn register(lib: &mut NodeLibrary) {
    lib.add(node(
        "split",
        "Splits a vector into its components: `x`, `y`, `z` are components 0, 1, 2 (`r`, \
         `g`, `b` of a color; `u`, `v` of a vec2). For a vec2, `z` is 0.",
        &[Type::Vec2, Type::Vec3, Type::Color],
        vec![port::generic("input", 0.0, "The vector to split.")],
        vec![
            port::out("x", Type::Float, "Component 0 (x, r or u)."),
            port::out("y", Type::Float, "Component 1 (y, g or v)."),
            port::out("z", Type::Float, "Component 2 (z or b); 0 for a vec2."),
        ],
        lower_split,
    ));
    lib.add(node(
        "merge",
        "Builds vectors from three floats: `outVec3 = (x, y, z)`, `outColor = (x, y, z)` as \
         r, g, b, `outVec2 = (x, y)` (`z` unused).",
        &[],
        vec![
            port::float("x", 0.0, "Component 0 (x, r or u)."),
            port::float("y", 0.0, "Component 1 (y, g or v)."),
            port::float("z", 0.0, "Component 2 (z or b)."),
        ],
        vec![
            port::out("outVec3", Type::Vec3, "`(x, y, z)` as a vec3."),
            port::out("outColor", Type::Color, "`(x, y, z)` as a color."),
            port::out("outVec2", Type::Vec2, "`(x, y)` as a vec2."),
        ],
        lower_merge,
    ));
    for (name, ty, default, doc) in constants() {
        lib.add(node(
            name,
            doc,
            &[],
            vec![port::input("value", ty, default, "The constant.")],
            vec![port::out("out", ty, "`value`.")],
            lower_constant,
        ));
    }
    lib.add(node(
        "switch",
        "Chooses one of `inputs` by index: `out = inputs[selector].value` when `0 ≤ selector \
         < len(inputs)`, else `default` (a negative or too large selector, or an empty \
         array). Lowered as a chain of `If` regions testing `selector == 0`, `== 1`, …, so a \
         constant selector reduces to the chosen input. Component parts are not carried.",
        FLOAT_TYPES,
        vec![
            port::int("selector", 0, "Index of the input to pass on."),
            port::array(
                "inputs",
                vec![("value", None)],
                "The candidates, in index order.",
            ),
            port::generic("default", 0.0, "Result when `selector` is out of range."),
        ],
        vec![port::out_generic("out", "The chosen value.")],
        lower_switch,
    ));
    lib.add(node(
        "condition",
        "Maya `condition`: `outColor = firstTerm <op> secondTerm ? colorIfTrue : \
         colorIfFalse`, lowered as an `If` region. Comparisons are IEEE: with a NaN term \
         every operation is false except `notEqual`, which is true. Component parts are not \
         carried (both arms are plain colors).",
        &[],
        vec![
            port::float("firstTerm", 0.0, "Left-hand side of the comparison."),
            port::float("secondTerm", 0.0, "Right-hand side of the comparison."),
            port::option(
                "operation",
                "equal",
                &[
                    "equal",
                    "notEqual",
                    "greaterThan",
                    "greaterOrEqual",
                    "lessThan",
                    "lessOrEqual",
                ],
                "The comparison.",
            ),
            port::color("colorIfTrue", [0.0; 3], "Result when the comparison holds."),
            port::color("colorIfFalse", [1.0; 3], "Result otherwise."),
        ],
        vec![port::out("outColor", Type::Color, "The chosen color.")],
        lower_condition,
    ));
}

fn lower_split(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let v = n.get("input");
    let width = b.ty(v).width();
    let outs = (0..3)
        .map(|i| {
            let c = if i < width {
                b.extract(v, i)
            } else {
                b.float(0.0)
            };
            LowVal::plain(c)
        })
        .collect();
    Ok(outs)
}

fn lower_merge(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let (x, y, z) = (n.get("x"), n.get("y"), n.get("z"));
    let v3 = b.construct(Type::Vec3, &[x, y, z]);
    let c = b.construct(Type::Color, &[x, y, z]);
    let v2 = b.construct(Type::Vec2, &[x, y]);
    Ok(vec![LowVal::plain(v3), LowVal::plain(c), LowVal::plain(v2)])
}

fn lower_constant(_b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    Ok(vec![LowVal::plain(n.get("value"))])
}

/// `elems[i]` if `sel == i` for some `i ≥ start`, else `default`, as nested `If`s.
fn switch_chain(
    b: &mut Builder,
    sel: Value,
    elems: &[Value],
    start: usize,
    default: Value,
) -> Value {
    let Some(&here) = elems.get(start) else {
        return default;
    };
    let Ok(index) = i32::try_from(start) else {
        return default;
    };
    let k = b.int(index);
    let hit = b.binary(BinOp::Eq, sel, k);
    let r = b.if_(
        hit,
        |_| vec![here],
        |b| vec![switch_chain(b, sel, elems, start + 1, default)],
    );
    r[0]
}

fn lower_switch(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let sel = n.get("selector");
    let default = n.get("default");
    let mut elems = Vec::new();
    for (i, rec) in n.array("inputs").iter().enumerate() {
        let v = rec
            .first()
            .ok_or_else(|| format!("inputs[{i}] has no `value` field"))?;
        elems.push(v.value);
    }
    Ok(vec![LowVal::plain(switch_chain(
        b, sel, &elems, 0, default,
    ))])
}

fn lower_condition(b: &mut Builder, n: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let op = match n.string("operation") {
        "equal" => BinOp::Eq,
        "notEqual" => BinOp::Ne,
        "greaterThan" => BinOp::Gt,
        "greaterOrEqual" => BinOp::Ge,
        "lessThan" => BinOp::Lt,
        "lessOrEqual" => BinOp::Le,
        other => {
            return Err(format!(
                "operation `{other}` is not one of equal, notEqual, greaterThan, \
                 greaterOrEqual, lessThan, lessOrEqual"
            ));
        }
    };
    let cond = b.binary(op, n.get("firstTerm"), n.get("secondTerm"));
    let (t, f) = (n.get("colorIfTrue"), n.get("colorIfFalse"));
    let r = b.if_(cond, |_| vec![t], |_| vec![f]);
    Ok(vec![LowVal::plain(r[0])])
}
