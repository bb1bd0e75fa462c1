//! An OSL shader group ([`crate::group`]) lowered into one program: each layer is its
//! shader lowered into the same builder, in order, its parameters bound to the group's
//! instance values (program parameters named `layer.param`) or to the outputs of the
//! earlier layers connected to them, `Ci` and the messages ([`super::messages`]) handed on
//! from layer to layer; the last layer's outputs are the program's. Unused layers cost nothing: the optimizer removes what no
//! output reads. It owns how a group binds its layers; the layers' lowering is the
//! shaders'.

use super::{LayerInput, Lower, Ty, Val, messages, osl};
use crate::ast::{self, Item, ShaderKind};
use crate::diag::{Diagnostic, Diagnostics};
use crate::group::{Group, LoadedGroup, ParamValue};
use shadenet_graph::ConstValue;
use shadenet_graph::ir::{Builder, Program};
use std::collections::{BTreeMap, HashMap};

/// Lowers the shader group `loaded` (its shaders parsed) into one program named after its
/// last layer. Errors name the group statement or the shader source at fault.
pub fn compile_group(loaded: &LoadedGroup) -> Result<Program, Diagnostics> {
    crate::on_big_stack(|| compile_here(loaded))
}

fn compile_here(loaded: &LoadedGroup) -> Result<Program, Diagnostics> {
    let shaders = shader_defs(loaded)?;
    check_connections(&loaded.group)?;
    // A group whose layers set messages is lowered twice: the first finds their types.
    let types = if loaded.shaders.values().any(messages::calls_setmessage) {
        lower_layers(loaded, &shaders, BTreeMap::new()).1
    } else {
        BTreeMap::new()
    };
    lower_layers(loaded, &shaders, types).0
}

/// One lowering of the group's layers with the messages of `message_types` declared; the
/// program, and the messages the layers set with their types.
fn lower_layers(
    loaded: &LoadedGroup,
    shaders: &[&ast::ShaderDef],
    message_types: BTreeMap<String, Ty>,
) -> (Result<Program, Diagnostics>, BTreeMap<String, Ty>) {
    let g = &loaded.group;
    let last = g.layers.last().expect("a parsed group has a layer");
    let mut b = Builder::new(&last.name.name);
    let mut done: HashMap<&str, Vec<(String, Val)>> = HashMap::new();
    let mut ci = Val::Closure(Box::default());
    let mut diags = Diagnostics::new();
    let mut outputs = Vec::new();
    let mut found: BTreeMap<String, (Ty, crate::source::Span)> = BTreeMap::new();
    // The globals once for all layers (the streams they read are the same).
    let mut globals = {
        let mut first = Lower::new(&loaded.shaders[&last.shader.name]);
        first.message_types = message_types.clone();
        first.osl_globals(&mut b);
        first.scopes.swap_remove(0)
    };
    for (layer, shader) in g.layers.iter().zip(shaders) {
        let parsed = &loaded.shaders[&layer.shader.name];
        let mut lower = Lower::new(parsed);
        lower.scopes[0] = globals.clone();
        lower.message_types = message_types.clone();
        lower.messages_found = std::mem::take(&mut found);
        lower.prefix = format!("{}.", layer.name.name);
        for p in &layer.params {
            lower.inputs.insert(
                p.name.name.clone(),
                LayerInput::Values(p.values.clone(), p.span),
            );
        }
        for c in g
            .connections
            .iter()
            .filter(|c| c.to.0.name == layer.name.name)
        {
            let upstream = &done[c.from.0.name.as_str()];
            let Some((_, v)) = upstream.iter().find(|(n, _)| *n == c.from.1.name) else {
                let names: Vec<&str> = upstream.iter().map(|(n, _)| n.as_str()).collect();
                diags.push(Diagnostic::error(
                    format!(
                        "layer `{}` has no output `{}` (its outputs: {})",
                        c.from.0.name,
                        c.from.1.name,
                        names.join(", ")
                    ),
                    c.from.1.span,
                    "not an output",
                ));
                continue;
            };
            lower.inputs.insert(
                c.to.1.name.clone(),
                LayerInput::Connected(v.clone(), c.span),
            );
        }
        for c in &g.connections {
            if c.to.0.name == layer.name.name {
                *lower.connections.entry(c.to.1.name.clone()).or_default() |= 1;
            }
            if c.from.0.name == layer.name.name {
                *lower.connections.entry(c.from.1.name.clone()).or_default() |= 2;
            }
        }
        let out = lower.osl_layer(&mut b, shader, ci.clone());
        // The messages this layer leaves are the next layers' to read.
        for (name, var) in &lower.scopes[0] {
            if messages::is_message_var(name) {
                globals.insert(name.clone(), var.clone());
            }
        }
        found = std::mem::take(&mut lower.messages_found);
        for (name, input) in &lower.inputs {
            let at = match input {
                LayerInput::Values(_, at) | LayerInput::Connected(_, at) => *at,
            };
            let names: Vec<&str> = shader.params.iter().map(|p| p.name.name.as_str()).collect();
            lower.diags.push(Diagnostic::error(
                format!(
                    "shader `{}` (layer `{}`) has no input parameter `{name}` (its parameters: {})",
                    layer.shader.name,
                    layer.name.name,
                    names.join(", ")
                ),
                at,
                "unknown parameter",
            ));
        }
        diags.0.extend(lower.diags.0);
        if let Some((_, c)) = out.iter().find(|(n, _)| n == "Ci") {
            ci = c.clone();
        }
        outputs = out.clone();
        done.insert(layer.name.name.as_str(), out);
    }
    let types = found.into_iter().map(|(n, (t, _))| (n, t)).collect();
    if diags.has_errors() {
        return (Err(diags), types);
    }
    osl::declare_outputs(&mut b, outputs);
    let program = b.finish().map_err(|e| {
        Diagnostic::error_nowhere(format!("internal error: the lowered group is invalid: {e}"))
            .into()
    });
    (program, types)
}

/// Each layer's shader definition, in layer order: an OSL `surface` or `shader` named as
/// the layer's `shader` statement says, in its source file.
fn shader_defs(loaded: &LoadedGroup) -> Result<Vec<&ast::ShaderDef>, Diagnostics> {
    let mut out = Vec::new();
    let mut errors = Diagnostics::new();
    for layer in &loaded.group.layers {
        let parsed = &loaded.shaders[&layer.shader.name];
        let def = parsed.file.items.iter().find_map(|i| match i {
            Item::Shader(s) if s.name.name == layer.shader.name => Some(s),
            _ => None,
        });
        match def {
            Some(s) if matches!(s.kind, ShaderKind::Surface | ShaderKind::Shader) => out.push(s),
            Some(s) => errors.push(Diagnostic::error(
                format!(
                    "layer `{}`: only `surface` and `shader` shaders are built in groups",
                    layer.name.name
                ),
                s.kind_span,
                "not built yet",
            )),
            None => errors.push(Diagnostic::error(
                format!(
                    "the source of `{}` defines no shader of that name",
                    layer.shader.name
                ),
                layer.shader.span,
                "this shader",
            )),
        }
    }
    if errors.has_errors() {
        Err(errors)
    } else {
        Ok(out)
    }
}

/// Layer names are unique, and each connection runs from an earlier layer to a later one.
fn check_connections(g: &Group) -> Result<(), Diagnostics> {
    let mut errors = Diagnostics::new();
    let mut index: HashMap<&str, usize> = HashMap::new();
    for (k, l) in g.layers.iter().enumerate() {
        if index.insert(l.name.name.as_str(), k).is_some() {
            errors.push(Diagnostic::error(
                format!("a second layer named `{}`", l.name.name),
                l.name.span,
                "layer names must be unique",
            ));
        }
    }
    let names: Vec<&str> = g.layers.iter().map(|l| l.name.name.as_str()).collect();
    for c in &g.connections {
        let from = index.get(c.from.0.name.as_str());
        let to = index.get(c.to.0.name.as_str());
        for (layer, found) in [(&c.from.0, from), (&c.to.0, to)] {
            if found.is_none() {
                errors.push(Diagnostic::error(
                    format!(
                        "no layer `{}` in the group (its layers: {})",
                        layer.name,
                        names.join(", ")
                    ),
                    layer.span,
                    "unknown layer",
                ));
            }
        }
        if let (Some(f), Some(t)) = (from, to)
            && f >= t
        {
            errors.push(Diagnostic::error(
                format!(
                    "`{}` is not an earlier layer than `{}`: a connection runs from an earlier layer to a later one",
                    c.from.0.name, c.to.0.name
                ),
                c.span,
                "backwards connection",
            ));
        }
    }
    if errors.has_errors() {
        Err(errors)
    } else {
        Ok(())
    }
}

impl<'a> Lower<'a> {
    /// Parameter `p` of a group layer, bound to what the group gives it.
    pub(crate) fn layer_input(&mut self, b: &mut Builder, p: &'a ast::Param, input: LayerInput) {
        if p.ty.base == ast::BaseType::String {
            match input {
                LayerInput::Values(v, at) => match v.as_slice() {
                    [ParamValue::Str(s)] => self.declare(&p.name, Val::Str(s.clone()), true),
                    _ => self.error(
                        format!("`{}` is a string: give one string", p.name.name),
                        at,
                        "here",
                    ),
                },
                // An upstream string output: the string it holds when compiled.
                LayerInput::Connected(s @ Val::Str(_), _) => self.declare(&p.name, s, true),
                LayerInput::Connected(v, at) => self.error(
                    format!(
                        "string parameter `{}` takes a string output, not {}",
                        p.name.name,
                        super::an(v.type_name())
                    ),
                    at,
                    "not a string",
                ),
            }
            return;
        }
        let Some(ty) = self.declared_type(&p.ty) else {
            return;
        };
        let uniform = !matches!(p.ty.rate, Some((ast::Rate::Varying, _)));
        match input {
            LayerInput::Connected(v, at) => {
                let v = self.coerce(b, v, ty, at);
                // A connected parameter takes the upstream value, varying or not.
                self.declare(&p.name, v, false);
            }
            LayerInput::Values(values, at) => {
                let Some(c) = instance_value(ty, &values) else {
                    self.error(
                        format!(
                            "`param {}`: ({}) is not {} value",
                            p.name.name,
                            show(&values),
                            super::an(ty.name())
                        ),
                        at,
                        "wrong value",
                    );
                    return;
                };
                let v = b.param(&format!("{}{}", self.prefix, p.name.name), c);
                self.declare(
                    &p.name,
                    Val::V {
                        v,
                        ty,
                        varying: false,
                    },
                    uniform,
                );
            }
        }
    }
}

/// The constant of type `ty` that `values` give: one number for a float or int (an integer
/// for an int), one or three for a triple.
fn instance_value(ty: Ty, values: &[ParamValue]) -> Option<ConstValue> {
    let nums: Option<Vec<f64>> = values
        .iter()
        .map(|v| match v {
            ParamValue::Number(x) if x.abs() <= f32::MAX as f64 => Some(*x),
            _ => None,
        })
        .collect();
    super::constant_of(ty, &nums?)
}

fn show(values: &[ParamValue]) -> String {
    values
        .iter()
        .map(|v| match v {
            ParamValue::Number(x) => x.to_string(),
            ParamValue::Str(s) => format!("{s:?}"),
        })
        .collect::<Vec<_>>()
        .join(", ")
}
