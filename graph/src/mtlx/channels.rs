//! The 1.38 `channels` attribute: a swizzle of a connected output (`"r"`, `"xy"`, `"bgr"`,
//! constants `0`/`1`).
//!
//! This module owns turning a swizzle into a component connection or a combine node; it
//! must not resolve nodes.

use super::document::Input;
use super::error::MtlxError;
use super::value::mx_name;
use crate::network::NodeSpec;
use crate::types::Type;
use serde_json::{Map, Value as Json, json};

fn component(c: char) -> Option<&'static str> {
    Some(match c {
        'r' | 'x' => "x",
        'g' | 'y' => "y",
        'b' | 'z' => "z",
        'a' | 'w' => "w",
        _ => return None,
    })
}

/// The connection for `src` (of MaterialX type `src_ty`) swizzled by `channels` into type
/// `to`; a multi-channel swizzle adds a combine node to `extra`.
pub fn swizzle(
    node: &str,
    i: &Input,
    channels: &str,
    src: &str,
    src_ty: &str,
    to: Type,
    extra: &mut Vec<NodeSpec>,
) -> Result<Json, MtlxError> {
    let err = |m: String| MtlxError::Document {
        at: i.pos.clone(),
        msg: format!(
            "node `{node}` input `{}`: channels `{channels}`: {m}",
            i.name
        ),
    };
    let chars: Vec<char> = channels.chars().collect();
    if chars.len() != to.width() || !(to == Type::Float || to.is_vector()) {
        return Err(err(format!(
            "{} channels cannot make a {}",
            chars.len(),
            mx_name(to)
        )));
    }
    let width = match src_ty {
        "float" => 1,
        "vector2" => 2,
        "vector3" | "color3" => 3,
        "vector4" | "color4" => 4,
        other => return Err(err(format!("cannot swizzle a {other}"))),
    };
    let one = |c: char| -> Result<Json, MtlxError> {
        match c {
            '0' => Ok(json!(0.0)),
            '1' => Ok(json!(1.0)),
            _ => match component(c) {
                Some(k) if width == 1 && k == "x" => Ok(Json::String(src.to_string())),
                Some(k)
                    if ["x", "y", "z", "w"]
                        .iter()
                        .position(|x| *x == k)
                        .unwrap_or(9)
                        < width =>
                {
                    Ok(Json::String(format!("{src}.{k}")))
                }
                _ => Err(err(format!("`{c}` is not a channel of a {src_ty}"))),
            },
        }
    };
    if chars.len() == 1 {
        return one(chars[0]);
    }
    let name = format!("{node}_{}_swizzle", i.name);
    let mut inputs = Map::new();
    for (k, c) in chars.iter().enumerate() {
        inputs.insert(format!("in{}", k + 1), one(*c)?);
    }
    extra.push(NodeSpec {
        name: name.clone(),
        ty: format!("ND_combine{}_{}", chars.len(), mx_name(to)),
        inputs,
    });
    Ok(Json::String(format!("{name}.out")))
}
