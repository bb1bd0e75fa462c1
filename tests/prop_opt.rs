//! Differential property test of the optimizer: for random valid networks over the whole node
//! library, the unoptimized program and `opt::run`'s program give **bit-identical** outputs
//! in the f32 interpreter (DESIGN §5: every pass keeps f32 results bit for bit).
//!
//! The generator is driven by `NodeLibrary::standard().defs()`, not by a list of node names,
//! so a new node is covered as soon as it is registered. For each node it draws:
//!
//! - the generic type `T` (one of the def's `generic` types; the type the linker then infers
//!   from what was connected is recomputed by [`infer_generic`], the documented rule);
//! - per input port: unset (the default, or the port's implicit stream), a literal of the
//!   port's type (ordinary values, and often hard ones: ±0, ±1, ±1e30, ±1e-30, ±1e38, a
//!   denormal; never NaN or inf, which the format cannot hold), a connection to an earlier
//!   node whose output type is coercible to the port (`link::coercible`), possibly selecting
//!   one component (`n3.outColor.g`, `.x`, `.u`) and possibly spelled `{"connect": …}`;
//! - string ports: one of the port's `options` (spaces, interpolations, operations…);
//! - array ports (ramp keys, switch inputs): 0–4 records whose fields are literals or
//!   connections;
//! - int ports (switch selectors, octaves): small ints (in and out of range) and extremes,
//!   literal or connected to a `constantInt`, so constant, uniform (a parameter under class
//!   compilation) and — through `condition` terms — varying conditionals all occur.
//!
//! Excluded: light nodes as shading nodes (they have no outputs; instead every network gets
//! 0–3 light nodes of the library's light types with random literal parameters, kept inside
//! the constraints their constructors check: cone angle in [0, 180], dropoff ≥ 0, nonzero
//! direction), and the `file` texture node (see [`EXCLUDED`]): it needs an image on disk.
//!
//! Material outputs: 1–3, on random node outputs (whole or one component); half the networks
//! end with a surface node whose `outColor` is the first output, so render components occur.
//!
//! The property, per case: 1–3 random [`Specialization`]s (a component mask over
//! `program.components`, a random ray-type set, bake on or off, every pass on or off, a round
//! budget), random environment transforms (camera, object) and 1–4 random fragments (P, N
//! unit or not or zero, uv, I, dPdu…, a ray type from the specialized set, a ray depth). The
//! optimized program must validate, must not grow (`op_count` ≤ original + values moved into
//! the prelude) and must give the same output slots, the same output floats (`f32::to_bits`)
//! and the same count of guarded non-finite values as the original, both run with the
//! specialization's mask as `ShadeCtx::mask`.
//!
//! 256 cases by default; `PROPTEST_CASES=2000 cargo test --test prop_opt` runs more (proptest
//! reads the variable). A failure prints the network JSON (runnable with `shadenet shade`),
//! the specialization, the fragment, the output that differs and both programs' IR, after
//! shrinking to a small network.

use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::FileFailurePersistence;
use serde_json::{Map, Number, Value as Json, json};
use shadenet_graph::compile_json;
use shadenet_graph::ir::{Program, validate};
use shadenet_graph::link::coercible;
use shadenet_graph::nodes::{NodeDef, NodeKind, NodeLibrary, PortType};
use shadenet_graph::opt::{self, Passes, Specialization};
use shadenet_graph::types::Type;
use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv, Transform};
use std::cell::Cell;
use std::sync::LazyLock;

/// Library nodes the generator never uses, and why.
const EXCLUDED: &[(&str, &str)] = &[(
    "file",
    "reads an image file from disk (tests/textures.rs covers it)",
)];

/// At most this many random shading nodes (plus one surface node and 3 lights: ≤ 24).
const MAX_NODES: usize = 20;

/// Input choices drawn per node; every def must have at most this many inputs.
const MAX_PORTS: usize = 16;

static LIB: LazyLock<NodeLibrary> = LazyLock::new(NodeLibrary::standard);

/// The shading nodes the generator draws from.
static SHADING: LazyLock<Vec<&'static NodeDef>> = LazyLock::new(|| {
    let defs: Vec<&NodeDef> = LIB
        .defs()
        .iter()
        .filter(|d| matches!(d.kind, NodeKind::Shading))
        .filter(|d| !EXCLUDED.iter().any(|(n, _)| *n == d.name))
        .collect();
    for d in &defs {
        assert!(
            d.inputs.len() <= MAX_PORTS,
            "node `{}` has {} inputs: raise MAX_PORTS",
            d.name,
            d.inputs.len()
        );
    }
    defs
});

/// Surface nodes (their `outColor` carries render components).
static SURFACES: LazyLock<Vec<&'static NodeDef>> = LazyLock::new(|| {
    let v: Vec<&NodeDef> = SHADING
        .iter()
        .copied()
        .filter(|d| d.category == "surface")
        .collect();
    assert!(!v.is_empty(), "the library has no surface node");
    v
});

/// Light nodes.
static LIGHTS: LazyLock<Vec<&'static NodeDef>> = LazyLock::new(|| {
    LIB.defs()
        .iter()
        .filter(|d| matches!(d.kind, NodeKind::Light(_)))
        .collect()
});

// ---- the random choices (what proptest generates and shrinks) ----

/// A literal, interpreted by the port's type: floats from `vals` (cycled to the width),
/// `int` for int ports, `flag` for bools (and, on vector ports, "write one number to
/// broadcast"; on matrix ports, "write 4 rows"); `int` also picks a string option.
#[derive(Clone, Debug)]
struct Lit {
    vals: Vec<f64>,
    int: i32,
    flag: bool,
}

impl Lit {
    fn zero() -> Lit {
        Lit {
            vals: vec![0.0],
            int: 0,
            flag: true,
        }
    }
}

/// A connection: `src` picks among the compatible earlier outputs (whole or one component);
/// `letters` the component spelling (x/y/z, r/g/b, u/v); `object` the `{"connect": …}` form.
#[derive(Clone, Debug)]
struct Conn {
    src: Index,
    letters: u8,
    object: bool,
}

/// One input's choice.
#[derive(Clone, Debug)]
enum In {
    Unset,
    Lit(Lit),
    Conn(Conn),
}

/// One node: its def (an index into the eligible defs), its generic type (an index into the
/// def's `generic`), one choice per input port, and the records of its array ports.
#[derive(Clone, Debug)]
struct NodeChoice {
    def: Index,
    generic: Index,
    inputs: Vec<In>,
    arrays: Vec<Vec<Vec<In>>>,
}

/// A material output: a node, one of its outputs, a component (0: the whole value).
#[derive(Clone, Debug)]
struct OutChoice {
    node: Index,
    output: Index,
    comp: u8,
    letters: u8,
}

/// A light node: its def and one literal choice per input.
#[derive(Clone, Debug)]
struct LightChoice {
    def: Index,
    inputs: Vec<In>,
}

/// The specialization: components (masked to the program's), ray types (nonzero 5 bits),
/// bake, passes (fold, specialize, dead_branch, cse, dce, hoist), round budget.
#[derive(Clone, Debug)]
struct SpecChoice {
    components: u32,
    ray_types: u32,
    bake: bool,
    passes: [bool; 6],
    budget: usize,
}

/// A normal: unit, as drawn, or zero.
#[derive(Clone, Debug)]
enum NormalChoice {
    Unit([f64; 3]),
    Raw([f64; 3]),
    Zero,
}

/// One fragment.
#[derive(Clone, Debug)]
struct FragChoice {
    p: [f64; 3],
    n: NormalChoice,
    ng: NormalChoice,
    i: [f64; 3],
    uv: [f64; 2],
    dpdu: [f64; 3],
    dpdv: [f64; 3],
    dpdx: [f64; 3],
    dpdy: [f64; 3],
    time: f64,
    ray: Index,
    depth: i32,
}

/// The environment: an optional look-at camera (eye, target) and an optional object
/// transform (scale, translation); identity otherwise.
#[derive(Clone, Debug)]
struct EnvChoice {
    camera: Option<([f64; 3], [f64; 3])>,
    object: Option<([f64; 3], [f64; 3])>,
}

/// One test case.
#[derive(Clone, Debug)]
struct Case {
    nodes: Vec<NodeChoice>,
    surface: Option<NodeChoice>,
    lights: Vec<LightChoice>,
    outputs: Vec<OutChoice>,
    reverse: bool,
    specs: Vec<SpecChoice>,
    env: EnvChoice,
    frags: Vec<FragChoice>,
}

// ---- strategies ----

/// Identity elements and their negations: where folding's exact identities (`x * 1`,
/// `x + 0`, `x - 0`, `x / 1`) apply and where inexact ones (`x * 0`, `x - x`) would show.
const UNITS: &[f64] = &[0.0, -0.0, 1.0, -1.0];

/// Hard literal values: huge, tiny, a denormal, the edge of f32's range.
const HARD: &[f64] = &[
    0.5, 2.0, 1e30, -1e30, 1e-30, -1e-30, 1e38, -1e38, 1e-45, 3.0,
];

fn float_s() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => (-80i32..=80).prop_map(|k| f64::from(k) / 8.0),
        3 => prop::sample::select(UNITS),
        2 => prop::sample::select(HARD),
        1 => (-1.0e6f32..1.0e6f32).prop_map(f64::from),
    ]
}

fn vec3_s() -> impl Strategy<Value = [f64; 3]> {
    prop::array::uniform3(float_s())
}

fn int_s() -> impl Strategy<Value = i32> {
    prop_oneof![
        8 => -2i32..=6,
        1 => prop::sample::select(&[i32::MIN, i32::MAX, -1000, 1000, 17][..]),
    ]
}

fn lit_s() -> impl Strategy<Value = Lit> {
    let vals = prop_oneof![
        4 => prop::collection::vec(float_s(), 1..=3),
        1 => prop::collection::vec(float_s(), 16),
    ];
    (vals, int_s(), any::<bool>()).prop_map(|(vals, int, flag)| Lit { vals, int, flag })
}

fn conn_s() -> impl Strategy<Value = Conn> {
    (any::<Index>(), any::<u8>(), prop::bool::weighted(0.2)).prop_map(|(src, letters, object)| {
        Conn {
            src,
            letters,
            object,
        }
    })
}

fn in_s() -> impl Strategy<Value = In> {
    prop_oneof![
        2 => Just(In::Unset),
        3 => lit_s().prop_map(In::Lit),
        5 => conn_s().prop_map(In::Conn),
    ]
}

fn field_s() -> impl Strategy<Value = In> {
    prop_oneof![lit_s().prop_map(In::Lit), conn_s().prop_map(In::Conn)]
}

fn node_s() -> impl Strategy<Value = NodeChoice> {
    (
        any::<Index>(),
        any::<Index>(),
        prop::collection::vec(in_s(), MAX_PORTS),
        prop::collection::vec(
            prop::collection::vec(prop::collection::vec(field_s(), 0..=3), 0..=4),
            0..=2,
        ),
    )
        .prop_map(|(def, generic, inputs, arrays)| NodeChoice {
            def,
            generic,
            inputs,
            arrays,
        })
}

fn light_s() -> impl Strategy<Value = LightChoice> {
    (
        any::<Index>(),
        prop::collection::vec(
            prop_oneof![Just(In::Unset), lit_s().prop_map(In::Lit)],
            MAX_PORTS,
        ),
    )
        .prop_map(|(def, inputs)| LightChoice { def, inputs })
}

fn out_s() -> impl Strategy<Value = OutChoice> {
    (
        any::<Index>(),
        any::<Index>(),
        prop_oneof![3 => Just(0u8), 1 => 1u8..=3],
        any::<u8>(),
    )
        .prop_map(|(node, output, comp, letters)| OutChoice {
            node,
            output,
            comp,
            letters,
        })
}

fn spec_s() -> impl Strategy<Value = SpecChoice> {
    (
        any::<u32>(),
        1u32..32,
        any::<bool>(),
        prop::array::uniform6(prop::bool::weighted(0.7)),
        prop_oneof![3 => Just(16usize), 1 => 0usize..=4],
    )
        .prop_map(|(components, ray_types, bake, passes, budget)| SpecChoice {
            components,
            ray_types,
            bake,
            passes,
            budget,
        })
}

fn normal_s() -> impl Strategy<Value = NormalChoice> {
    prop_oneof![
        4 => vec3_s().prop_map(NormalChoice::Unit),
        2 => vec3_s().prop_map(NormalChoice::Raw),
        1 => Just(NormalChoice::Zero),
    ]
}

fn frag_s() -> impl Strategy<Value = FragChoice> {
    (
        (vec3_s(), normal_s(), normal_s(), vec3_s()),
        prop::array::uniform2(float_s()),
        (vec3_s(), vec3_s(), vec3_s(), vec3_s()),
        (float_s(), any::<Index>(), 0i32..=6),
    )
        .prop_map(
            |((p, n, ng, i), uv, (dpdu, dpdv, dpdx, dpdy), (time, ray, depth))| FragChoice {
                p,
                n,
                ng,
                i,
                uv,
                dpdu,
                dpdv,
                dpdx,
                dpdy,
                time,
                ray,
                depth,
            },
        )
}

fn env_s() -> impl Strategy<Value = EnvChoice> {
    (
        prop::option::of((vec3_s(), vec3_s())),
        prop::option::of((vec3_s(), vec3_s())),
    )
        .prop_map(|(camera, object)| EnvChoice { camera, object })
}

fn case_s() -> impl Strategy<Value = Case> {
    (
        prop::collection::vec(node_s(), 1..=MAX_NODES),
        prop::option::of(node_s()),
        prop::collection::vec(light_s(), 0..=3),
        prop::collection::vec(out_s(), 1..=3),
        prop::bool::weighted(0.25),
        prop::collection::vec(spec_s(), 1..=3),
        env_s(),
        prop::collection::vec(frag_s(), 1..=4),
    )
        .prop_map(
            |(nodes, surface, lights, outputs, reverse, specs, env, frags)| Case {
                nodes,
                surface,
                lights,
                outputs,
                reverse,
                specs,
                env,
                frags,
            },
        )
}

// ---- from choices to a network ----

/// A node already placed: its name and typed outputs.
struct Placed {
    name: String,
    outputs: Vec<(&'static str, Type)>,
    /// Whether a later node already reads it.
    used: Cell<bool>,
}

/// What feeds a generic node's `T` (the linker's inputs to its choice).
#[derive(Default)]
struct GenericFeed {
    literal_width: usize,
    conns: Vec<Type>,
}

/// The linker's choice of `T` (docs/network-format.md, "Generic nodes"): the widest of the
/// connected types and literal shapes; a 3-wide value is a color if any connection is one, a
/// vec3 if any connection is one, else a color where the node allows it; then mapped onto the
/// def's `generic` types (color ↔ vec3; a float where floats are not allowed becomes the
/// first allowed type).
fn infer_generic(def: &NodeDef, feed: &GenericFeed) -> Type {
    let width = feed
        .conns
        .iter()
        .map(|t| t.width())
        .chain([feed.literal_width, 1])
        .max()
        .unwrap_or(1);
    let any_color = feed.conns.contains(&Type::Color);
    let any_vec3 = feed.conns.contains(&Type::Vec3);
    let t = match width {
        1 => Type::Float,
        2 => Type::Vec2,
        3 if any_color || (!any_vec3 && def.generic.contains(&Type::Color)) => Type::Color,
        3 => Type::Vec3,
        w => panic!(
            "generator bug: a {w}-wide value feeds generic node {}",
            def.name
        ),
    };
    if def.generic.contains(&t) {
        t
    } else if t == Type::Color && def.generic.contains(&Type::Vec3) {
        Type::Vec3
    } else if t == Type::Vec3 && def.generic.contains(&Type::Color) {
        Type::Color
    } else if t == Type::Float {
        def.generic[0]
    } else {
        panic!(
            "generator bug: {} cannot take {t} (generic {:?})",
            def.name, def.generic
        )
    }
}

fn num(x: f64) -> Json {
    Json::Number(Number::from_f64(x).expect("finite literal"))
}

/// A literal of type `ty` (not a string).
fn literal(ty: Type, l: &Lit) -> Json {
    let v = |k: usize| l.vals[k % l.vals.len()];
    match ty {
        Type::Bool => Json::Bool(l.flag),
        Type::Int => json!(l.int),
        Type::Float => num(v(0)),
        t if t.is_vector() && l.flag => num(v(0)),
        Type::Vec2 | Type::Vec3 | Type::Color | Type::Vec4 | Type::Color4 => {
            Json::Array((0..ty.width()).map(|k| num(v(k))).collect())
        }
        Type::Matrix33 | Type::Matrix44 if l.flag => {
            let n = ty.matrix_size();
            Json::Array(
                (0..n)
                    .map(|r| Json::Array((0..n).map(|c| num(v(r * n + c))).collect()))
                    .collect(),
            )
        }
        Type::Matrix33 | Type::Matrix44 => {
            Json::Array((0..ty.width()).map(|k| num(v(k))).collect())
        }
        Type::String | Type::Closure(_) => {
            unreachable!("string literals are picked from options; closures are never generated")
        }
    }
}

/// Every earlier output that may feed a port of type `want`: (node, output, component),
/// nodes that nothing reads yet last (so [`recent`] prefers them and few nodes are dead).
fn candidates(placed: &[Placed], want: Type) -> Vec<(usize, usize, Option<u8>)> {
    let mut c = Vec::new();
    for (j, p) in placed.iter().enumerate() {
        for (o, (_, ty)) in p.outputs.iter().enumerate() {
            if coercible(*ty, want) {
                c.push((j, o, None));
            }
            if ty.is_vector() && coercible(Type::Float, want) {
                for k in 0..ty.width() {
                    c.push((j, o, Some(k as u8)));
                }
            }
        }
    }
    c.sort_by_key(|(j, _, _)| !placed[*j].used.get());
    c
}

/// An index into `len` candidates listed oldest first, skewed towards the most recent ones
/// (so chains are deep and most nodes reach an output); shrinks towards the most recent.
fn recent(i: Index, len: usize) -> usize {
    let u = i.index(1 << 16) as f64 / f64::from(1u32 << 16);
    len - 1 - ((u * u * len as f64) as usize).min(len - 1)
}

/// `node.output[.component]`, the component spelled with one of the letter sets its width
/// allows.
fn reference(p: &Placed, o: usize, comp: Option<u8>, letters: u8) -> String {
    let (out, ty) = p.outputs[o];
    match comp {
        None => format!("{}.{out}", p.name),
        Some(k) => {
            let sets: &[&[&str]] = if ty.width() == 2 {
                &[&["x", "y"], &["r", "g"], &["u", "v"]]
            } else {
                &[&["x", "y", "z"], &["r", "g", "b"]]
            };
            let set = sets[letters as usize % sets.len()];
            format!("{}.{out}.{}", p.name, set[k as usize])
        }
    }
}

/// The JSON for one value of type `want`; a generic port's literal shape or connected type
/// is recorded in `feed`.
fn value(placed: &[Placed], want: Type, choice: &In, feed: Option<&mut GenericFeed>) -> Json {
    match choice {
        In::Unset => literal(want, &Lit::zero()),
        In::Lit(l) => {
            if let Some(f) = feed
                && want.is_vector()
                && !l.flag
            {
                f.literal_width = f.literal_width.max(want.width());
            }
            literal(want, l)
        }
        In::Conn(c) => {
            let cands = candidates(placed, want);
            if cands.is_empty() {
                return literal(want, &Lit::zero());
            }
            let (j, o, comp) = cands[recent(c.src, cands.len())];
            placed[j].used.set(true);
            if let Some(f) = feed {
                f.conns.push(if comp.is_some() {
                    Type::Float
                } else {
                    placed[j].outputs[o].1
                });
            }
            let r = reference(&placed[j], o, comp, c.letters);
            if c.object {
                json!({ "connect": r })
            } else {
                Json::String(r)
            }
        }
    }
}

/// Places one shading node: returns its JSON and its typed outputs.
fn place(placed: &[Placed], name: &str, def: &'static NodeDef, n: &NodeChoice) -> (Json, Placed) {
    let chosen = if def.generic.is_empty() {
        Type::Float
    } else {
        def.generic[n.generic.index(def.generic.len())]
    };
    let mut feed = GenericFeed::default();
    let mut inputs = Map::new();
    let mut array_port = 0;
    for (p, choice) in def.inputs.iter().zip(&n.inputs) {
        match &p.ty {
            PortType::Simple(Type::String) => {
                // A string port takes a literal option; free-form strings are left unset.
                if !matches!(choice, In::Unset) && !p.options.is_empty() {
                    let pick = match choice {
                        In::Lit(l) => l.int.unsigned_abs() as usize,
                        In::Conn(c) => c.letters as usize,
                        In::Unset => unreachable!(),
                    };
                    let o = p.options[pick % p.options.len()];
                    inputs.insert(p.name.into(), Json::String(o.into()));
                }
            }
            PortType::Simple(ty) => {
                if !matches!(choice, In::Unset) {
                    inputs.insert(p.name.into(), value(placed, *ty, choice, None));
                }
            }
            PortType::Generic => {
                if !matches!(choice, In::Unset) {
                    let v = value(placed, chosen, choice, Some(&mut feed));
                    inputs.insert(p.name.into(), v);
                }
            }
            PortType::Array(fields) => {
                let recs = n.arrays.get(array_port).cloned().unwrap_or_default();
                array_port += 1;
                if matches!(choice, In::Unset) {
                    continue;
                }
                let mut arr = Vec::new();
                for rec in &recs {
                    let mut m = Map::new();
                    for (fi, (fname, fty)) in fields.iter().enumerate() {
                        let c = rec.get(fi).unwrap_or(&In::Unset);
                        let v = match fty {
                            Some(t) => value(placed, *t, c, None),
                            None => value(placed, chosen, c, Some(&mut feed)),
                        };
                        m.insert((*fname).into(), v);
                    }
                    arr.push(Json::Object(m));
                }
                inputs.insert(p.name.into(), Json::Array(arr));
            }
        }
    }
    let t = if def.generic.is_empty() {
        Type::Float
    } else {
        infer_generic(def, &feed)
    };
    let outputs = def
        .outputs
        .iter()
        .map(|o| (o.name, o.ty.unwrap_or(t)))
        .collect();
    let node = json!({ "name": name, "type": def.name, "inputs": Json::Object(inputs) });
    (
        node,
        Placed {
            name: name.to_string(),
            outputs,
            used: Cell::new(false),
        },
    )
}

/// A light node with random literal parameters inside the ranges its constructor accepts.
fn light(name: &str, l: &LightChoice) -> Json {
    let def = LIGHTS[l.def.index(LIGHTS.len())];
    let mut inputs = Map::new();
    for (p, c) in def.inputs.iter().zip(&l.inputs) {
        let (In::Lit(lit), PortType::Simple(ty)) = (c, &p.ty) else {
            continue;
        };
        let x = lit.vals[0];
        let v = match (p.name, *ty) {
            ("coneAngle", _) => num(x.abs().min(180.0)),
            ("dropoff", _) => num(x.abs()),
            ("direction", Type::Vec3) => {
                let v = literal(Type::Vec3, lit);
                let zero = match &v {
                    Json::Array(a) => a.iter().all(|x| x.as_f64() == Some(0.0)),
                    x => x.as_f64() == Some(0.0),
                };
                if zero { json!([0, 0, -1]) } else { v }
            }
            (_, Type::String) => continue,
            (_, ty) => literal(ty, lit),
        };
        inputs.insert(p.name.into(), v);
    }
    json!({ "name": name, "type": def.name, "inputs": Json::Object(inputs) })
}

/// The network a case describes.
fn network(case: &Case) -> Json {
    let mut placed: Vec<Placed> = Vec::new();
    let mut nodes = Vec::new();
    for (i, n) in case.nodes.iter().enumerate() {
        let def = SHADING[n.def.index(SHADING.len())];
        let (json, p) = place(&placed, &format!("n{i}"), def, n);
        nodes.push(json);
        placed.push(p);
    }
    if let Some(s) = &case.surface {
        let def = SURFACES[s.def.index(SURFACES.len())];
        let (json, p) = place(&placed, "surf", def, s);
        nodes.push(json);
        placed.push(p);
    }
    for (k, l) in case.lights.iter().enumerate() {
        nodes.push(light(&format!("l{k}"), l));
    }
    let mut outputs = Map::new();
    for (k, o) in case.outputs.iter().enumerate() {
        let (name, j, out) = if k == 0 {
            // The first output is on the last node (the surface's outColor if there is one),
            // so the whole chain tends to be live.
            let j = placed.len() - 1;
            match case.surface {
                Some(_) => (
                    "color".to_string(),
                    j,
                    placed[j]
                        .outputs
                        .iter()
                        .position(|(n, _)| *n == "outColor")
                        .unwrap_or(0),
                ),
                None => ("o0".to_string(), j, o.output.index(placed[j].outputs.len())),
            }
        } else {
            // Prefer a node nothing reads yet (it would be dead otherwise).
            let unread: Vec<usize> = (0..placed.len())
                .filter(|&j| !placed[j].used.get())
                .collect();
            let j = if unread.is_empty() {
                o.node.index(placed.len())
            } else {
                unread[o.node.index(unread.len())]
            };
            (format!("o{k}"), j, o.output.index(placed[j].outputs.len()))
        };
        placed[j].used.set(true);
        let ty = placed[j].outputs[out].1;
        let comp = (o.comp > 0 && ty.is_vector()).then(|| (o.comp - 1) % ty.width() as u8);
        let comp = if k == 0 && case.surface.is_some() {
            None
        } else {
            comp
        };
        outputs.insert(
            name,
            Json::String(reference(&placed[j], out, comp, o.letters)),
        );
    }
    if case.reverse {
        // Connections may point forward: the linker orders the nodes.
        nodes.reverse();
    }
    json!({ "name": "prop", "version": 1, "nodes": nodes, "outputs": Json::Object(outputs) })
}

// ---- the property ----

fn f3(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

fn normal(n: &NormalChoice) -> [f32; 3] {
    match n {
        NormalChoice::Zero => [0.0; 3],
        NormalChoice::Raw(v) => f3(*v),
        NormalChoice::Unit(v) => {
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if l > 0.0 && l.is_finite() {
                f3(v.map(|x| x / l))
            } else {
                [0.0, 0.0, 1.0]
            }
        }
    }
}

/// The `k`-th set bit of `set` (a ray-type bit).
fn nth_bit(set: u32, k: Index) -> i32 {
    let bits: Vec<u32> = (0..32).filter(|b| set & (1 << b) != 0).collect();
    1 << bits[k.index(bits.len())]
}

fn fragment(f: &FragChoice, ray_types: u32) -> Fragment {
    Fragment {
        p: f3(f.p),
        n: normal(&f.n),
        ng: normal(&f.ng),
        i: f3(f.i),
        uv: f.uv.map(|x| x as f32),
        dpdu: f3(f.dpdu),
        dpdv: f3(f.dpdv),
        dpdx: f3(f.dpdx),
        dpdy: f3(f.dpdy),
        time: f.time as f32,
        // Any value: the area-light samples it seeds must not change under optimization.
        seed: (f.p[0].to_bits() ^ f.uv[1].to_bits()) as u32,
        ray_type: nth_bit(ray_types, f.ray),
        ray_depth: f.depth,
        rand: [f.uv[0] as f32, f.uv[1] as f32, f.time as f32, 0.5],
    }
}

fn environment(e: &EnvChoice, lights: &[shadenet_graph::nodes::LightDesc]) -> ShadeEnv {
    let mut env = ShadeEnv::with_lights(lights);
    if let Some((eye, target)) = e.camera {
        env.camera =
            Transform::look_at(eye, target, [0.0, 1.0, 0.0]).unwrap_or(Transform::IDENTITY);
    }
    if let Some((s, t)) = e.object {
        let m = [
            s[0], 0.0, 0.0, t[0], 0.0, s[1], 0.0, t[1], 0.0, 0.0, s[2], t[2], 0.0, 0.0, 0.0, 1.0,
        ];
        env.object = Transform::new(m).unwrap_or(Transform::IDENTITY);
    }
    env
}

fn specialization(s: &SpecChoice, components: usize) -> Specialization {
    let mask = if components >= 32 {
        u32::MAX
    } else {
        (1u32 << components) - 1
    };
    let [fold, specialize, dead_branch, cse, dce, hoist] = s.passes;
    Specialization {
        components: s.components & mask,
        ray_types: s.ray_types,
        bake: s.bake,
        passes: Passes {
            fold,
            specialize,
            dead_branch,
            cse,
            dce,
            hoist,
            unroll: true,
        },
        budget: s.budget,
    }
}

fn check(case: &Case) -> Result<(), TestCaseError> {
    let net = network(case);
    let src = serde_json::to_string_pretty(&net).expect("json");
    let compiled = match no_panic("compiling", &src, || compile_json(&src, &LIB))? {
        Ok(c) => c,
        Err(e) => {
            return Err(TestCaseError::fail(format!(
                "generator bug: the network does not compile: {e}\n{src}"
            )));
        }
    };
    let program = &compiled.program;
    prop_assert!(
        validate(program).is_ok(),
        "lowering produced an invalid program: {:?}\n{src}",
        validate(program)
    );
    let env = environment(&case.env, &compiled.lights);
    let original = Interpreter::<f32>::new(program).expect("no textures");
    for s in &case.specs {
        let spec = specialization(s, program.components.len());
        let what = format!("optimizing or shading with {spec:?}");
        no_panic(&what, &src, || {
            check_spec(case, &src, program, &original, &env, &spec)
        })??;
    }
    Ok(())
}

/// Runs `f`, turning a panic (a debug assertion in a pass, an interpreter bug) into a
/// failure that shows the network.
fn no_panic<R>(what: &str, src: &str, f: impl FnOnce() -> R) -> Result<R, TestCaseError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).map_err(|e| {
        let msg = e
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        TestCaseError::fail(format!("panic while {what}: {msg}\nnetwork:\n{src}"))
    })
}

/// Optimizes `program` for `spec` and compares it with `original` on every fragment.
fn check_spec(
    case: &Case,
    src: &str,
    program: &Program,
    original: &Interpreter<f32>,
    env: &ShadeEnv,
    spec: &Specialization,
) -> Result<(), TestCaseError> {
    let (optimized, report) = opt::run(program, spec);
    if let Err(e) = validate(&optimized) {
        return Err(TestCaseError::fail(format!(
            "the optimized program does not validate: {e}\nnetwork:\n{src}\nspec: {spec:?}\n\
             original:\n{program}\noptimized:\n{optimized}"
        )));
    }
    let bound = program.op_count() + optimized.prelude.body.len();
    prop_assert!(
        optimized.op_count() <= bound,
        "the optimizer grew the program: {} ops → {} (prelude {})\nnetwork:\n{src}\n\
         spec: {spec:?}\n{report}\noriginal:\n{program}\noptimized:\n{optimized}",
        program.op_count(),
        optimized.op_count(),
        optimized.prelude.body.len()
    );
    let opt_interp = Interpreter::<f32>::new(&optimized).expect("no textures");
    prop_assert_eq!(
        original.slots(),
        opt_interp.slots(),
        "output layout differs"
    );
    for f in &case.frags {
        let frag = fragment(f, spec.ray_types);
        let mut ctx = ShadeCtx::new(frag, env);
        ctx.mask = spec.components;
        let a = original.shade(&ctx);
        let b = opt_interp.shade(&ctx);
        let fail = |what: String| {
            TestCaseError::fail(format!(
                "{what}\nnetwork:\n{src}\nspec: {spec:?}\nenv: {:?}\nfragment: {frag:?}\n\
                 mask: {:#b}\noriginal outputs: {:?}\noptimized outputs: {:?}\n{report}\n\
                 original:\n{program}\noptimized:\n{optimized}",
                case.env, ctx.mask, a.values, b.values
            ))
        };
        for slot in original.slots() {
            let w = slot.ty.width().max(1);
            for k in 0..w {
                let (x, y) = (a.values[slot.offset + k], b.values[slot.offset + k]);
                if x.to_bits() != y.to_bits() {
                    let comp = slot
                        .component
                        .map(|c| format!(" (component {})", program.components[c as usize]))
                        .unwrap_or_default();
                    return Err(fail(format!(
                        "output `{}`{comp} [{k}] differs: original {x:e} ({:#010x}), \
                         optimized {y:e} ({:#010x})",
                        slot.name,
                        x.to_bits(),
                        y.to_bits()
                    )));
                }
            }
        }
        if a.nonfinite != b.nonfinite {
            return Err(fail(format!(
                "non-finite outputs guarded: original {}, optimized {}",
                a.nonfinite, b.nonfinite
            )));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig {
        // PROPTEST_CASES still sets the number of cases (it is read by `default()`).
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(
            "tests/prop_opt.proptest-regressions",
        ))),
        ..ProptestConfig::default()
    })]

    /// Optimized ≡ unoptimized, bit for bit, on random networks, specializations and
    /// fragments.
    #[test]
    fn optimizer_keeps_f32_results_bit_identical(case in case_s()) {
        check(&case)?;
    }
}

/// The generator reaches every eligible node type, with every input port set at least once
/// (a literal, a connection or an option), in a fixed-seed sample.
#[test]
fn generator_covers_the_library() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{Config, TestRng, TestRunner};
    use std::collections::HashSet;
    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::deterministic_rng(Default::default()),
    );
    let strategy = case_s();
    let mut seen: HashSet<(String, String)> = HashSet::new();
    let mut conns = 0;
    for _ in 0..400 {
        let case = strategy.new_tree(&mut runner).unwrap().current();
        let net = network(&case);
        for n in net["nodes"].as_array().unwrap() {
            let ty = n["type"].as_str().unwrap().to_string();
            seen.insert((ty.clone(), String::new()));
            for (port, v) in n["inputs"].as_object().unwrap() {
                seen.insert((ty.clone(), port.clone()));
                if v.is_string() || v.is_object() {
                    conns += 1;
                }
            }
        }
    }
    let mut missing = Vec::new();
    for d in SHADING.iter().chain(LIGHTS.iter()) {
        if !seen.contains(&(d.name.to_string(), String::new())) {
            missing.push(d.name.to_string());
        }
        for p in &d.inputs {
            let free_string =
                matches!(p.ty, PortType::Simple(Type::String)) && p.options.is_empty();
            if !free_string && !seen.contains(&(d.name.to_string(), p.name.to_string())) {
                missing.push(format!("{}.{}", d.name, p.name));
            }
        }
    }
    assert!(missing.is_empty(), "never generated: {missing:?}");
    assert!(conns > 1000, "too few connections: {conns}");
}

/// Prints what the generator makes (two sample networks and their IR, then averages over 200
/// cases: ops, components, `if` regions, outputs, lights, and the share of nodes that reach a
/// material output). For tuning the generator: `cargo test --test prop_opt generator_stats
/// -- --ignored --nocapture`.
#[test]
#[ignore]
fn generator_stats() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{Config, TestRng, TestRunner};
    use std::collections::HashSet;
    let mut runner = TestRunner::new_with_rng(
        Config::default(),
        TestRng::deterministic_rng(Default::default()),
    );
    let strategy = case_s();
    let n = 200;
    let (mut ops, mut comps, mut ifs, mut outs, mut lights, mut live, mut total) =
        (0, 0, 0, 0, 0, 0, 0);
    for i in 0..n {
        let case = strategy.new_tree(&mut runner).unwrap().current();
        let net = network(&case);
        let c = compile_json(&net.to_string(), &LIB).unwrap();
        ops += c.program.op_count();
        comps += c.program.components.len();
        outs += c.program.outputs.len();
        lights += c.lights.len();
        ifs += c.program.to_string().matches(" if ").count();
        // Nodes that reach an output (a fixed point over the connection strings).
        let nodes = net["nodes"].as_array().unwrap();
        let source = |v: &Json| v.as_str().unwrap().split('.').next().unwrap().to_string();
        let mut reach: HashSet<String> = net["outputs"]
            .as_object()
            .unwrap()
            .values()
            .map(source)
            .collect();
        loop {
            let before = reach.len();
            let reached: Vec<&Json> = nodes
                .iter()
                .filter(|m| reach.contains(m["name"].as_str().unwrap()))
                .collect();
            for node in reached {
                let text = node["inputs"].to_string();
                for m in nodes {
                    let name = m["name"].as_str().unwrap();
                    if text.contains(&format!("\"{name}.")) {
                        reach.insert(name.to_string());
                    }
                }
            }
            if reach.len() == before {
                break;
            }
        }
        live += reach.len();
        total += nodes.len() - c.lights.len();
        if i < 2 {
            println!(
                "{}\n{}",
                serde_json::to_string_pretty(&net).unwrap(),
                c.program
            );
        }
    }
    let avg = |x: usize| x as f64 / n as f64;
    println!(
        "per network: {:.1} ops, {:.2} components, {:.2} ifs, {:.2} outputs, {:.2} lights; \
         {live} of {total} shading nodes reach an output",
        avg(ops),
        avg(comps),
        avg(ifs),
        avg(outs),
        avg(lights)
    );
}
