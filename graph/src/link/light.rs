//! Light descriptions: a light node's checked inputs, which must all be literals or
//! defaults, become a [`LightDesc`] through its def's light function.
//!
//! It owns the "light parameters must be literals" rule and the light function's errors. It
//! must not check the inputs themselves (`check.rs` did).

use super::error::LinkError;
use super::linked::LinkedInput;
use crate::nodes::{LightDesc, LightFn, NodeDef, PortDefault};
use crate::types::ConstValue;

/// The light node `name` (of type `def`, whose light function is `make`) with checked
/// `inputs`: its description, or `None` with the errors reported.
pub(super) fn describe(
    name: &str,
    def: &NodeDef,
    make: LightFn,
    inputs: &[LinkedInput],
    errors: &mut Vec<LinkError>,
) -> Option<LightDesc> {
    let mut vals = Vec::new();
    let mut ok = true;
    for (p, li) in def.inputs.iter().zip(inputs) {
        vals.push(match (li, &p.default) {
            (LinkedInput::Const(c), _) => c.clone(),
            (LinkedInput::Str(s), _) => ConstValue::String(s.clone()),
            (LinkedInput::Default, PortDefault::Value(c)) => c.clone(),
            _ => {
                errors.push(LinkError::BadInput {
                    node: name.to_string(),
                    port: p.name.into(),
                    msg: "light parameters must be literals (connections to lights are not supported)".into(),
                });
                ok = false;
                ConstValue::Float(0.0)
            }
        });
    }
    if !ok {
        return None;
    }
    match make(name, &vals) {
        Ok(l) => Some(l),
        Err(msg) => {
            errors.push(LinkError::Lowering {
                node: name.to_string(),
                ty: def.name.into(),
                msg,
            });
            None
        }
    }
}
