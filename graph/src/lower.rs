//! Lowering: from a linked network to an IR [`Program`].
//!
//! Each node instance is lowered once, in dependency order, by its def's [`LowerFn`]; its
//! inputs are the values of what they are connected to (after the linker's coercions) or
//! their defaults. Material outputs become program outputs: an output whose value carries
//! render-component parts becomes one program output per part (DESIGN §8).
//!
//! # Stream overrides
//!
//! A lowering may ask for an input as it would be with some implicit streams replaced
//! ([`NodeInputs::reevaluate`]; DESIGN §3, thesis §4.2.7): `bump2d` reads its `bumpValue`
//! again with `uv` and `P` moved. The driver answers by lowering the nodes upstream of that
//! input once more, at the point where the lowering asks, with the overrides in force in
//! the builder ([`Builder::push_overrides`]: reading an overridden stream gives the override,
//! whether a node reads it through a port default or in its lowering). Every node records
//! the streams its value depends on (the streams its lowering read, and those of its
//! sources), so a node that depends on none of the overridden streams is not lowered again:
//! its first value is reused. Within one re-evaluation each upstream node is lowered at most
//! once (a memo per override set); re-evaluations nest (an overridden subgraph may itself
//! contain a bump), the inner overrides on top of the outer ones. Literal inputs keep their
//! parameters: a re-lowered node reads the same uniform parameters as the first lowering.

use crate::ir::{Builder, Program, Stream, Value};
use crate::link::{LinkError, LinkErrors, Linked, LinkedInput, Source};
use crate::nodes::{
    InputVal, LowVal, NodeDef, NodeInputs, NodeLibrary, PortDefault, PortType, Upstream,
};
use crate::transport::LightStrategy;
use crate::types::{ConstValue, Type};
use std::cell::RefCell;
use std::collections::HashMap;

/// Emits the value an unconnected port gets: its default, converted to the port's type
/// (a float default of a generic port is broadcast to `generic`).
pub fn default_input(b: &mut Builder, def: &NodeDef, port: usize, generic: Type) -> InputVal {
    let p = &def.inputs[port];
    match (&p.default, &p.ty) {
        (PortDefault::EmptyArray, _) => InputVal::Array(Vec::new()),
        (PortDefault::EmptyClosure, _) => {
            InputVal::Value(LowVal::closure(b, crate::closure::Closure::default()))
        }
        (PortDefault::Stream(s), _) => InputVal::Value(LowVal::plain(b.stream(*s))),
        (PortDefault::Value(ConstValue::String(s)), _) => InputVal::Str(s.clone()),
        (PortDefault::Value(c), PortType::Generic) => {
            InputVal::Value(LowVal::plain(constant_as(b, c, generic)))
        }
        (PortDefault::Value(c), _) => InputVal::Value(LowVal::plain(b.constant(c.clone()))),
    }
}

/// Converts constant `c` to type `ty`: floats broadcast to vectors, ints and bools converted
/// to floats, vec3 and color interchangeable. `None` if no such conversion exists.
pub fn convert_const(c: &ConstValue, ty: Type) -> Option<ConstValue> {
    match (c, ty) {
        (c, t) if c.ty() == t => Some(c.clone()),
        (ConstValue::Float(x), t) if t.is_vector() => {
            ConstValue::from_floats(t, &vec![*x; t.width()])
        }
        (ConstValue::Int(i), t) if t.is_float_based() => {
            ConstValue::from_floats(t, &vec![*i as f64; t.width()])
        }
        (ConstValue::Bool(x), t) if t.is_float_based() => {
            ConstValue::from_floats(t, &vec![*x as i32 as f64; t.width()])
        }
        (ConstValue::Bool(x), Type::Int) => Some(ConstValue::Int(*x as i32)),
        (ConstValue::Vec3(v) | ConstValue::Color(v), t) => ConstValue::from_floats(t, v),
        _ => None,
    }
}

/// Emits constant `c` as type `ty` (see [`convert_const`]).
pub fn constant_as(b: &mut Builder, c: &ConstValue, ty: Type) -> Value {
    match convert_const(c, ty) {
        Some(c) => b.constant(c),
        None => {
            b.fail(format!("constant {c} cannot be used as {ty}"));
            b.zero(ty)
        }
    }
}

/// Emits a literal set on a node's port as a uniform parameter `node.port` of type `ty`
/// (class compilation keeps it adjustable; baking turns it into a constant).
pub fn param_as(b: &mut Builder, name: &str, c: &ConstValue, ty: Type) -> Value {
    match convert_const(c, ty) {
        Some(c) => b.param(name, c),
        None => {
            b.fail(format!("parameter {name} = {c} cannot be used as {ty}"));
            b.zero(ty)
        }
    }
}

/// A literal input for [`lower_single`].
#[derive(Clone, Debug)]
pub enum Literal {
    /// A constant (strings go to string ports).
    Const(ConstValue),
    /// An array input: per element, per field, a constant.
    Array(Vec<Vec<ConstValue>>),
}

/// Lowers one node of type `node_type` with literal inputs (others at their defaults) into a
/// program whose outputs are the node's outputs, with component parts as separate outputs.
/// Used by tests and `shadenet nodes --eval`; the linker path is [`crate::link`].
pub fn lower_single(
    lib: &NodeLibrary,
    node_type: &str,
    generic: Type,
    inputs: &[(&str, Literal)],
) -> Result<Program, String> {
    let def = lib
        .get(node_type)
        .ok_or_else(|| format!("unknown node type `{node_type}`"))?;
    let mut b = Builder::new(node_type);
    let mut values = Vec::new();
    for (i, port) in def.inputs.iter().enumerate() {
        let lit = inputs.iter().find(|(n, _)| *n == port.name).map(|(_, l)| l);
        let v = match lit {
            None => default_input(&mut b, def, i, generic),
            Some(Literal::Const(ConstValue::String(s))) => InputVal::Str(s.clone()),
            Some(Literal::Const(c)) => {
                let ty = match &port.ty {
                    PortType::Simple(t) => *t,
                    _ => generic,
                };
                InputVal::Value(LowVal::plain(constant_as(&mut b, c, ty)))
            }
            Some(Literal::Array(elems)) => {
                let PortType::Array(fields) = &port.ty else {
                    return Err(format!("input {} is not an array", port.name));
                };
                let mut arr = Vec::new();
                for e in elems {
                    let mut rec = Vec::new();
                    for ((_, fty), c) in fields.iter().zip(e) {
                        let v = constant_as(&mut b, c, fty.unwrap_or(generic));
                        rec.push(LowVal::plain(v));
                    }
                    arr.push(rec);
                }
                InputVal::Array(arr)
            }
        };
        values.push(v);
    }
    for (n, _) in inputs {
        if def.input(n).is_none() {
            return Err(format!("node type `{node_type}` has no input `{n}`"));
        }
    }
    let upstream = Literals {
        def,
        generic,
        values: values.clone(),
        set: def
            .inputs
            .iter()
            .map(|p| inputs.iter().any(|(n, _)| *n == p.name))
            .collect(),
    };
    let ni = NodeInputs {
        node: node_type,
        def,
        generic,
        values,
        upstream: Some(&upstream),
    };
    let outs = (def.lower)(&mut b, &ni)?;
    if outs.len() != def.outputs.len() {
        return Err(format!(
            "lowering of `{node_type}` returned {} outputs, its def declares {}",
            outs.len(),
            def.outputs.len()
        ));
    }
    for (o, lv) in def.outputs.iter().zip(&outs) {
        declare_output(&mut b, o.name, lv);
    }
    b.finish()
}

/// Re-evaluation for [`lower_single`]: nothing is upstream of a literal, so a re-evaluated
/// input is its literal, or, for a port left at a stream default, the stream as overridden.
struct Literals<'a> {
    def: &'a NodeDef,
    generic: Type,
    values: Vec<InputVal>,
    /// Per port: whether a literal was given.
    set: Vec<bool>,
}

impl Upstream for Literals<'_> {
    fn reevaluate(
        &self,
        b: &mut Builder,
        port: &str,
        overrides: &[(Stream, Value)],
    ) -> Result<LowVal, String> {
        let pi = port_index(self.def, port)?;
        let value =
            if !self.set[pi] && matches!(self.def.inputs[pi].default, PortDefault::Stream(_)) {
                b.push_overrides(overrides);
                let v = default_input(b, self.def, pi, self.generic);
                b.pop_overrides(overrides.len());
                v
            } else {
                self.values[pi].clone()
            };
        single_value(value, port)
    }
}

fn port_index(def: &NodeDef, port: &str) -> Result<usize, String> {
    def.inputs
        .iter()
        .position(|p| p.name == port)
        .ok_or_else(|| format!("{} has no input `{port}`", def.name))
}

/// The value of a re-evaluated input; arrays and strings have no single value.
fn single_value(v: InputVal, port: &str) -> Result<LowVal, String> {
    match v {
        InputVal::Value(v) => Ok(v),
        _ => Err(format!(
            "input `{port}` is not a single value and cannot be re-evaluated"
        )),
    }
}

/// Declares a material output: one program output per component part when the value has
/// parts, else a single untagged output.
pub fn declare_output(b: &mut Builder, name: &str, v: &LowVal) {
    if let Some(c) = &v.closure {
        // A closure output (a material, shader or BSDF) shades: its radiance, by component.
        let lit = crate::closure::shade::surface(b, c);
        return declare_output(b, name, &lit);
    }
    if v.parts.is_empty() {
        b.output(name, None, v.value);
    } else {
        for (k, p) in &v.parts {
            b.output(name, Some(*k), *p);
        }
    }
}

/// Converts a connected value from `src.from` to `src.to` (the linker checked the pair):
/// component selection, broadcast, color ↔ vec3, int/bool → float. Component parts follow
/// the linear conversions.
fn coerce(b: &mut Builder, v: &LowVal, src: &Source) -> LowVal {
    use crate::nodes::lowering::map_parts;
    let mut v = v.clone();
    if let Some(k) = src.component {
        v = map_parts(b, &v, |b, x| b.extract(x, k as usize));
    }
    let (from, to) = (src.from, src.to);
    if from == to {
        v
    } else if from == Type::Float && to.is_vector() {
        map_parts(b, &v, |b, x| b.splat(to, x))
    } else if from.is_vector() && to.is_vector() {
        map_parts(b, &v, |b, x| b.retype(to, x))
    } else {
        LowVal::plain(b.convert(to, v.value))
    }
}

/// Declares the outputs of a closure-valued material output `name` (see
/// [`LowerOptions::closure_output`]).
pub type ClosureOutputFn = fn(&mut Builder, &str, &crate::closure::Closure);

/// How [`lower_with`] lowers a network.
#[derive(Clone, Copy, Debug, Default)]
pub struct LowerOptions {
    /// Replaces the surface lowering ([`crate::closure::shade::surface`]) of closure
    /// outputs: for tools that look at a material's lobes themselves (which lobes
    /// specialization leaves, [`crate::closure::probe::declare`]; a white furnace of its
    /// closure). `None` shades, as for rendering.
    pub closure_output: Option<ClosureOutputFn>,
    /// How the surface lowering lights closures (the renderer must weight BSDF-sampled rays
    /// with the same strategy); MIS by default.
    pub strategy: LightStrategy,
}

/// Lowers a linked network to a program. Only nodes that some material output depends on
/// are lowered. Errors name the node whose lowering failed. Closures are lit with MIS
/// ([`lower_with`] picks another strategy, [`LowerOptions`]).
pub fn lower(linked: &Linked, lib: &NodeLibrary) -> Result<Program, LinkErrors> {
    lower_with(linked, lib, LowerOptions::default())
}

/// [`lower`] with `opts`.
pub fn lower_with(
    linked: &Linked,
    lib: &NodeLibrary,
    opts: LowerOptions,
) -> Result<Program, LinkErrors> {
    let live = live_nodes(linked);
    let mut b = Builder::new(&linked.name);
    b.set_light_strategy(opts.strategy);
    let mut defs: Vec<Option<&NodeDef>> = Vec::with_capacity(linked.nodes.len());
    for (i, node) in linked.nodes.iter().enumerate() {
        let def = lib.get(&node.ty);
        if def.is_none() && live[i] {
            return Err(LinkErrors(vec![LinkError::UnknownType {
                node: node.name.clone(),
                ty: node.ty.clone(),
                hint: String::new(),
            }]));
        }
        defs.push(def);
    }
    let driver = Driver {
        linked,
        defs,
        done: RefCell::new(vec![Lowered::default(); linked.nodes.len()]),
    };
    let mut errors = Vec::new();
    for (i, node) in linked.nodes.iter().enumerate() {
        let Some(def) = driver.defs[i].filter(|_| live[i]) else {
            continue;
        };
        b.take_streams_read();
        let mut values = Vec::new();
        for (pi, input) in node.inputs.iter().enumerate() {
            let port_ty = match &def.inputs[pi].ty {
                PortType::Simple(t) => *t,
                _ => node.generic,
            };
            let v = match input {
                LinkedInput::Default => default_input(&mut b, def, pi, node.generic),
                LinkedInput::Array(elems) => {
                    let PortType::Array(fields) = &def.inputs[pi].ty else {
                        unreachable_input(&mut b, &mut errors, node, def, pi);
                        continue;
                    };
                    let mut arr = Vec::new();
                    for rec in elems {
                        let mut r = Vec::new();
                        for ((_, fty), fv) in fields.iter().zip(rec) {
                            let fty = fty.unwrap_or(node.generic);
                            let lv = match fv {
                                LinkedInput::Const(c) => LowVal::plain(constant_as(&mut b, c, fty)),
                                LinkedInput::Conn(s) => driver.source(&mut b, s),
                                _ => LowVal::plain(b.zero(fty)),
                            };
                            r.push(lv);
                        }
                        arr.push(r);
                    }
                    InputVal::Array(arr)
                }
                LinkedInput::Const(c) => {
                    let name = format!("{}.{}", node.name, def.inputs[pi].name);
                    InputVal::Value(LowVal::plain(param_as(&mut b, &name, c, port_ty)))
                }
                LinkedInput::Str(s) => InputVal::Str(s.clone()),
                LinkedInput::Conn(s) => InputVal::Value(driver.source(&mut b, s)),
            };
            values.push(v);
        }
        let upstream = NodeUpstream {
            driver: &driver,
            node: i,
            values: values.clone(),
        };
        let ni = NodeInputs {
            node: &node.name,
            def,
            generic: node.generic,
            values: values.clone(),
            upstream: Some(&upstream),
        };
        let outs = match (def.lower)(&mut b, &ni) {
            Ok(o) if o.len() == def.outputs.len() => o,
            result => {
                let msg = match result {
                    Ok(o) => format!(
                        "internal error: lowering returned {} outputs, the def declares {}",
                        o.len(),
                        def.outputs.len()
                    ),
                    Err(msg) => msg,
                };
                errors.push(LinkError::Lowering {
                    node: node.name.clone(),
                    ty: node.ty.clone(),
                    msg,
                });
                def.outputs
                    .iter()
                    .map(|o| LowVal::plain(b.zero(o.ty.unwrap_or(node.generic))))
                    .collect()
            }
        };
        let mut streams = b.take_streams_read();
        let done = &mut *driver.done.borrow_mut();
        for_each_source(&node.inputs, &mut |s| streams |= done[s.node].streams);
        done[i] = Lowered {
            outs,
            inputs: values,
            streams,
        };
    }
    declare_outputs(&mut b, &driver, &opts, &mut errors);
    if !errors.is_empty() {
        return Err(LinkErrors(errors));
    }
    let internal = |msg: String| {
        LinkErrors(vec![LinkError::Lowering {
            node: linked.name.clone(),
            ty: "(program)".into(),
            msg: format!("internal error: {msg}"),
        }])
    };
    let program = b.finish().map_err(internal)?;
    // Validate once: after this, nothing downstream may panic on the program.
    crate::ir::validate(&program).map_err(|e| internal(e.to_string()))?;
    Ok(program)
}

/// Which nodes reach a material output (indices into `linked.nodes`).
fn live_nodes(linked: &Linked) -> Vec<bool> {
    let mut live = vec![false; linked.nodes.len()];
    for (_, s) in &linked.outputs {
        live[s.node] = true;
    }
    for i in (0..linked.nodes.len()).rev() {
        if !live[i] {
            continue;
        }
        for input in &linked.nodes[i].inputs {
            mark_sources(input, &mut live);
        }
    }
    live
}

/// Declares the material outputs: plain values as outputs, closures lit by the surface
/// lowering (or handed to `opts.closure_output`) once their unbuilt lobes are dropped; a
/// closure that keeps an unbuilt lobe is an error in `errors`.
fn declare_outputs(
    b: &mut Builder,
    driver: &Driver,
    opts: &LowerOptions,
    errors: &mut Vec<LinkError>,
) {
    for (name, s) in &driver.linked.outputs {
        let mut v = driver.source(b, s);
        if let Some(c) = &v.closure {
            match c.without_unbuilt(b.program()) {
                Ok(c) => v.closure = Some(std::sync::Arc::new(c)),
                Err(msg) => {
                    errors.push(LinkError::Lowering {
                        node: name.clone(),
                        ty: "material output".into(),
                        msg,
                    });
                    continue;
                }
            }
        }
        match (opts.closure_output, &v.closure) {
            (Some(hook), Some(c)) => hook(b, name, c),
            _ => declare_output(b, name, &v),
        }
    }
}

/// What the first lowering of a node left behind.
#[derive(Clone, Debug, Default)]
struct Lowered {
    /// Its outputs.
    outs: Vec<LowVal>,
    /// The inputs it was lowered with.
    inputs: Vec<InputVal>,
    /// The streams its value depends on (bits [`Stream::bit`]): those its lowering and its
    /// port defaults read, and those of its sources.
    streams: u32,
}

/// The lowering driver's state, shared with the [`Upstream`] it hands every lowering.
struct Driver<'l> {
    linked: &'l Linked,
    /// Each node's definition (`None` for unknown types of dead nodes).
    defs: Vec<Option<&'l NodeDef>>,
    /// The first lowering of every node lowered so far.
    done: RefCell<Vec<Lowered>>,
}

/// Per re-evaluation: each node's outputs under the current overrides.
type Memo = HashMap<usize, Vec<LowVal>>;

impl Driver<'_> {
    /// The value a connection delivers in the first lowering, coerced to the port's type.
    fn source(&self, b: &mut Builder, s: &Source) -> LowVal {
        let v = self.done.borrow()[s.node].outs.get(s.output).cloned();
        match v {
            Some(v) => coerce(b, &v, s),
            None => LowVal::plain(b.zero(s.to)),
        }
    }

    /// Node `j`'s outputs under the overrides in force: its first lowering where it depends
    /// on none of them, else a new lowering (once per memo).
    fn relower(&self, b: &mut Builder, j: usize, memo: &mut Memo) -> Result<Vec<LowVal>, String> {
        if let Some(outs) = memo.get(&j) {
            return Ok(outs.clone());
        }
        let first = self.done.borrow()[j].clone();
        let (node, def) = match self.defs[j] {
            Some(def) if first.streams & b.overridden_streams() != 0 => {
                (&self.linked.nodes[j], def)
            }
            _ => return Ok(first.outs),
        };
        let mut values = Vec::with_capacity(node.inputs.len());
        for (pi, input) in node.inputs.iter().enumerate() {
            let v = match (input, first.inputs.get(pi)) {
                (LinkedInput::Conn(s), _) => InputVal::Value(self.relowered_source(b, s, memo)?),
                (LinkedInput::Default, _)
                    if matches!(def.inputs[pi].default, PortDefault::Stream(_)) =>
                {
                    default_input(b, def, pi, node.generic)
                }
                (LinkedInput::Array(elems), Some(InputVal::Array(old))) => {
                    let mut arr = Vec::with_capacity(elems.len());
                    for (rec, old_rec) in elems.iter().zip(old) {
                        let mut r = Vec::with_capacity(rec.len());
                        for (fv, old_v) in rec.iter().zip(old_rec) {
                            r.push(match fv {
                                LinkedInput::Conn(s) => self.relowered_source(b, s, memo)?,
                                _ => old_v.clone(),
                            });
                        }
                        arr.push(r);
                    }
                    InputVal::Array(arr)
                }
                (_, Some(old)) => old.clone(),
                (_, None) => return Err(format!("`{}` was not lowered", node.name)),
            };
            values.push(v);
        }
        let upstream = NodeUpstream {
            driver: self,
            node: j,
            values: values.clone(),
        };
        let ni = NodeInputs {
            node: &node.name,
            def,
            generic: node.generic,
            values,
            upstream: Some(&upstream),
        };
        let outs =
            (def.lower)(b, &ni).map_err(|msg| format!("re-evaluating `{}`: {msg}", node.name))?;
        if outs.len() != def.outputs.len() {
            return Err(format!("re-evaluating `{}`: wrong output count", node.name));
        }
        memo.insert(j, outs.clone());
        Ok(outs)
    }

    fn relowered_source(
        &self,
        b: &mut Builder,
        s: &Source,
        memo: &mut Memo,
    ) -> Result<LowVal, String> {
        let outs = self.relower(b, s.node, memo)?;
        let v = outs.get(s.output).ok_or_else(|| {
            format!(
                "`{}` has no output {}",
                self.linked.nodes[s.node].name, s.output
            )
        })?;
        Ok(coerce(b, v, s))
    }
}

/// The [`Upstream`] of one node: re-evaluates its inputs through the driver.
struct NodeUpstream<'d, 'l> {
    driver: &'d Driver<'l>,
    node: usize,
    /// The inputs the node is being lowered with (literals are kept as they are).
    values: Vec<InputVal>,
}

impl Upstream for NodeUpstream<'_, '_> {
    fn reevaluate(
        &self,
        b: &mut Builder,
        port: &str,
        overrides: &[(Stream, Value)],
    ) -> Result<LowVal, String> {
        let d = self.driver;
        let node = &d.linked.nodes[self.node];
        let def = d.defs[self.node].ok_or_else(|| format!("`{}` has no definition", node.name))?;
        let pi = port_index(def, port)?;
        b.push_overrides(overrides);
        let result = match &node.inputs[pi] {
            LinkedInput::Conn(s) => d.relowered_source(b, s, &mut Memo::new()),
            LinkedInput::Default if matches!(def.inputs[pi].default, PortDefault::Stream(_)) => {
                single_value(default_input(b, def, pi, node.generic), port)
            }
            _ => match self.values.get(pi) {
                Some(v) => single_value(v.clone(), port),
                None => Err(format!("input `{port}` of `{}` has no value", node.name)),
            },
        };
        b.pop_overrides(overrides.len());
        result
    }
}

fn unreachable_input(
    b: &mut Builder,
    errors: &mut Vec<LinkError>,
    node: &crate::link::LinkedNode,
    def: &NodeDef,
    pi: usize,
) {
    b.fail("array input on a non-array port");
    errors.push(LinkError::Lowering {
        node: node.name.clone(),
        ty: node.ty.clone(),
        msg: format!(
            "internal error: input `{}` is not an array port",
            def.inputs[pi].name
        ),
    });
}

/// Calls `f` on every connection among `inputs` (array fields included).
fn for_each_source(inputs: &[LinkedInput], f: &mut impl FnMut(&Source)) {
    for input in inputs {
        match input {
            LinkedInput::Conn(s) => f(s),
            LinkedInput::Array(a) => a.iter().for_each(|rec| for_each_source(rec, f)),
            _ => {}
        }
    }
}

fn mark_sources(input: &LinkedInput, live: &mut [bool]) {
    match input {
        LinkedInput::Conn(s) => live[s.node] = true,
        LinkedInput::Array(a) => a.iter().flatten().for_each(|i| mark_sources(i, live)),
        _ => {}
    }
}

/// A network compiled to a program, with the lights it declares.
#[derive(Clone, Debug)]
pub struct Compiled {
    /// The material program.
    pub program: Program,
    /// The network's lights.
    pub lights: Vec<crate::nodes::LightDesc>,
}

/// Any error from network text to program.
#[derive(Debug, thiserror::Error)]
pub enum CompileError {
    /// The text is not a valid network file.
    #[error("malformed network")]
    Parse(#[from] crate::network::ParseError),
    /// Linking or lowering found problems.
    #[error(transparent)]
    Link(#[from] LinkErrors),
}

/// Parses, links and lowers a network given as JSON text.
pub fn compile_json(src: &str, lib: &NodeLibrary) -> Result<Compiled, CompileError> {
    let net = crate::network::Network::from_json(src)?;
    let linked = crate::link::link(&net, lib)?;
    let program = lower(&linked, lib)?;
    Ok(Compiled {
        program,
        lights: linked.lights,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::{BinOp, Op};
    use crate::nodes::{NodeKind, port};

    /// `clock`: outputs its `t` input (default: the `time` stream) plus the `uv` it reads
    /// itself; `later`: its `input` re-evaluated at `time + 1`; `fixed`: a constant.
    fn library() -> NodeLibrary {
        fn def(
            name: &'static str,
            inputs: Vec<crate::nodes::PortDef>,
            lower: crate::nodes::LowerFn,
        ) -> NodeDef {
            NodeDef {
                name,
                category: "test",
                doc: "",
                generic: &[],
                inputs,
                outputs: vec![port::out("out", Type::Float, "")],
                lower,
                kind: NodeKind::Shading,
            }
        }
        let mut lib = NodeLibrary::new();
        lib.add(def(
            "clock",
            vec![port::stream("t", Type::Float, Stream::Time, "")],
            |b, inp| {
                let uv = b.stream(Stream::Uv);
                let u = b.extract(uv, 0);
                Ok(vec![LowVal::plain(b.add(inp.get("t"), u))])
            },
        ));
        lib.add(def("fixed", vec![port::float("k", 2.0, "")], |b, inp| {
            let k = inp.get("k");
            Ok(vec![LowVal::plain(b.mul(k, k))])
        }));
        lib.add(def(
            "later",
            vec![port::float("input", 0.0, "")],
            |b, inp| {
                let t = b.stream(Stream::Time);
                let one = b.float(1.0);
                let t1 = b.add(t, one);
                let v = inp.reevaluate(b, "input", &[(Stream::Time, t1)])?;
                let wrong = inp.reevaluate(b, "input", &[(Stream::Time, one), (Stream::Uv, one)]);
                assert!(wrong.unwrap_err().contains("stream uv is a vec2"));
                Ok(vec![v])
            },
        ));
        lib
    }

    fn compile(src: &str) -> Program {
        compile_json(src, &library()).unwrap().program
    }

    /// The op of output `name`.
    fn out<'p>(p: &'p Program, name: &str) -> &'p Op {
        let o = p.outputs.iter().find(|o| o.name == name).unwrap();
        p.op(o.value)
    }

    #[test]
    fn reevaluation_replaces_any_stream_upstream() {
        let p = compile(
            r#"{"nodes": [
                {"name": "c", "type": "clock"},
                {"name": "l", "type": "later", "inputs": {"input": "c.out"}}],
              "outputs": {"first": "c.out", "later": "l.out"}}"#,
        );
        // `later` is clock's `t + u` with t = time + 1: a second add whose left operand is
        // the override.
        let Op::Binary(BinOp::Add, t, _) = out(&p, "later") else {
            panic!("{p}");
        };
        assert!(
            matches!(p.op(*t), Op::Binary(BinOp::Add, s, _) if *p.op(*s) == Op::Stream(Stream::Time)),
            "{p}"
        );
        let Op::Binary(BinOp::Add, t0, _) = out(&p, "first") else {
            panic!("{p}");
        };
        assert_eq!(p.op(*t0), &Op::Stream(Stream::Time));
        // The time stream is read once; uv is read by each lowering of `clock`.
        let count = |op: Op| p.listed().iter().filter(|v| *p.op(**v) == op).count();
        assert_eq!(
            count(Op::Stream(Stream::Time)),
            2,
            "clock's default and later's: {p}"
        );
        assert_eq!(count(Op::Stream(Stream::Uv)), 2, "{p}");
        crate::ir::validate(&p).unwrap();
    }

    #[test]
    fn nodes_that_do_not_read_the_stream_are_reused() {
        let p = compile(
            r#"{"nodes": [
                {"name": "f", "type": "fixed", "inputs": {"k": 3}},
                {"name": "l", "type": "later", "inputs": {"input": "f.out"}}],
              "outputs": {"first": "f.out", "later": "l.out"}}"#,
        );
        let first = p.outputs.iter().find(|o| o.name == "first").unwrap().value;
        let later = p.outputs.iter().find(|o| o.name == "later").unwrap().value;
        assert_eq!(first, later, "{p}");
        assert_eq!(
            p.params.len(),
            1,
            "the literal's parameter is declared once"
        );
        // A literal input re-evaluates to its parameter.
        let p = compile(
            r#"{"nodes": [{"name": "l", "type": "later", "inputs": {"input": 5}}],
              "outputs": {"later": "l.out"}}"#,
        );
        assert_eq!(out(&p, "later"), &Op::Param(0));
        assert_eq!(p.params.len(), 1);
    }

    #[test]
    fn lower_single_reevaluates_literals_and_stream_defaults() {
        let lib = library();
        let p = lower_single(&lib, "clock", Type::Float, &[]).unwrap();
        assert!(matches!(out(&p, "out"), Op::Binary(BinOp::Add, ..)));
        // `later` alone: its unconnected input is the literal default.
        let p = lower_single(&lib, "later", Type::Float, &[]).unwrap();
        assert!(matches!(out(&p, "out"), Op::Const(_)), "{p}");
    }

    #[test]
    fn without_a_driver_reevaluation_is_an_error() {
        let lib = library();
        let def = lib.get("later").unwrap();
        let mut b = Builder::new("t");
        let ni = NodeInputs {
            node: "l",
            def,
            generic: Type::Float,
            values: vec![default_input(&mut b, def, 0, Type::Float)],
            upstream: None,
        };
        let one = b.float(1.0);
        let e = ni
            .reevaluate(&mut b, "input", &[(Stream::Time, one)])
            .unwrap_err();
        assert!(e.contains("no lowering driver"), "{e}");
        let e = ni.reevaluate(&mut b, "nope", &[]).unwrap_err();
        assert!(e.contains("no input `nope`"), "{e}");
    }
}
