//! Phase 6, material outputs: resolves each `"name": "node.output[.component]"` of the
//! network's `outputs` to a [`Source`] on a linked shading node.
//!
//! It owns the output errors ([`LinkError::BadOutput`], [`LinkError::NoOutputs`]). It must
//! not change the nodes: an output only points at one.

use super::error::LinkError;
use super::generic::Typed;
use super::linked::Source;
use super::resolve::Resolver;
use crate::network::Network;
use crate::nodes::NodeKind;

/// The material outputs of `net`, in declaration order (those that resolve).
pub(super) fn material(
    net: &Network,
    resolver: &Resolver<'_, '_>,
    typed: &Typed<'_, '_>,
    pos: &[usize],
    errors: &mut Vec<LinkError>,
) -> Vec<(String, Source)> {
    let mut outputs = Vec::new();
    if net.outputs.is_empty() {
        errors.push(LinkError::NoOutputs);
    }
    for (name, target) in &net.outputs {
        let Some(t) = target.as_str() else {
            errors.push(LinkError::BadOutput {
                output: name.clone(),
                msg: format!("expects \"node.output\", not {target}"),
            });
            continue;
        };
        let mut errs = Vec::new();
        let Some(c) = resolver.conn(t, "(outputs)", name, &mut errs) else {
            errors.extend(errs.into_iter().map(|e| {
                LinkError::BadOutput {
                    output: name.clone(),
                    msg: e
                        .to_string()
                        .replace(&format!("node `(outputs)` input `{name}`: "), ""),
                }
            }));
            continue;
        };
        if !matches!(typed.flat[c.node].def.kind, NodeKind::Shading) {
            errors.push(LinkError::BadOutput {
                output: name.clone(),
                msg: format!("`{t}` is a light; lights have no outputs"),
            });
            continue;
        }
        let full = typed.out_ty(c.node, c.output);
        if c.component
            .is_some_and(|k| !full.is_vector() || k as usize >= full.width())
        {
            errors.push(LinkError::BadOutput {
                output: name.clone(),
                msg: format!("`{t}`: a {full} has no such component"),
            });
            continue;
        }
        let ty = typed.conn_ty(&c);
        outputs.push((
            name.clone(),
            Source {
                node: pos[c.node],
                output: c.output,
                component: c.component,
                from: ty,
                to: ty,
            },
        ));
    }
    outputs
}
