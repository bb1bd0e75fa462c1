//! OSL's `gettextureinfo(filename, name, output value)`: a texture file's header, read
//! while the shader compiles through the parse's [`TextureInfoSource`] (the texture system;
//! this crate reads no images) and lowered to constants — as OSL's optimizer folds it for a
//! constant file name. It owns these rules:
//!
//! - `"exists"` (int): 1 where the file can be read as a texture, else 0; the call returns
//!   1 either way (OSL's one query that succeeds for a missing file).
//! - `"resolution"` (int[2]), `"channels"` (int), `"type"` and `"textureformat"` (string,
//!   `"Plain Texture"`), `"datawindow"` and `"displaywindow"` (int[4]: 0, 0, width − 1,
//!   height − 1): written and 1 where the file can be read; 0 and the output unchanged
//!   where it cannot.
//! - The file name is a compile-time string (as all ours); a `<UDIM>` pattern, another
//!   query name and an output of another type are errors naming them, and so is a compile
//!   without a texture source.

use super::{Lower, Ty, Val, an};
use crate::TextureInfoSource;
use crate::ast::Expr;
use crate::source::Span;
use shadenet_graph::ir::Builder;

/// The queries built, for errors.
const QUERIES: &str =
    "exists, resolution, channels, type, textureformat, datawindow, displaywindow";

impl<'a> Lower<'a> {
    /// `gettextureinfo(filename, name, value)`: the call's int result, the value stored.
    pub(crate) fn gettextureinfo(
        &mut self,
        b: &mut Builder,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let int = |b: &mut Builder, i: i32| Val::V {
            v: b.int(i),
            ty: Ty::Int,
            varying: false,
        };
        let ([(Val::Str(file), fat), (Val::Str(query), qat), (old, _)], [_, _, target]) =
            (vals, args)
        else {
            self.error(
                "`gettextureinfo` takes (string filename, string name, output value)",
                span,
                "gettextureinfo",
            );
            return int(b, 0);
        };
        let Some(TextureInfoSource(source)) = self.texture_info else {
            self.error(
                "`gettextureinfo` reads the texture's header while the shader compiles, and this compile has no texture system: load the shader through shadenet (`shadenet check|compile|shade|render`, `shadenet::shader::load`)",
                span,
                "gettextureinfo",
            );
            return int(b, 0);
        };
        if file.contains("<UDIM>") {
            self.error(
                "`gettextureinfo` of a UDIM pattern is not built (name one tile's file)",
                *fat,
                "a UDIM pattern",
            );
            return int(b, 0);
        }
        let info = source(file).ok();
        let (w, h, ch) = info.map_or((0, 0, 0), |i| {
            (i.width as i32, i.height as i32, i.channels as i32)
        });
        let ints = |b: &mut Builder, xs: &[i32]| {
            let vs: Vec<Val> = xs.iter().map(|x| int(b, *x)).collect();
            match vs.as_slice() {
                [one] => one.clone(),
                _ => Val::Array(vs),
            }
        };
        let value = match query.as_str() {
            "exists" => ints(b, &[i32::from(info.is_some())]),
            "resolution" => ints(b, &[w, h]),
            "channels" => ints(b, &[ch]),
            "datawindow" | "displaywindow" => ints(b, &[0, 0, w - 1, h - 1]),
            "type" | "textureformat" => Val::Str("Plain Texture".into()),
            other => {
                self.error(
                    format!("`gettextureinfo`: \"{other}\" is not built (built: {QUERIES})"),
                    *qat,
                    "this query",
                );
                return int(b, 0);
            }
        };
        if !same_shape(&value, old) {
            self.error(
                format!(
                    "`gettextureinfo(…, \"{query}\", …)` writes {} (not into {})",
                    shape_name(&value),
                    an(old.type_name())
                ),
                target.span,
                "wrong type",
            );
            return int(b, 0);
        }
        if info.is_some() || query == "exists" {
            self.store_output_arg(b, target, value, (3, "gettextureinfo"));
            return int(b, 1);
        }
        int(b, 0)
    }
}

/// Whether a query's value fits an output holding `old`: an int into an int, an int array
/// into an int array of its length, a string into a string.
fn same_shape(value: &Val, old: &Val) -> bool {
    match (value, old) {
        (Val::V { .. }, Val::V { ty: Ty::Int, .. }) | (Val::Str(_), Val::Str(_)) => true,
        (Val::Array(v), Val::Array(o)) => {
            v.len() == o.len() && o.iter().all(|e| matches!(e, Val::V { ty: Ty::Int, .. }))
        }
        _ => false,
    }
}

/// A query value's type in messages.
fn shape_name(value: &Val) -> String {
    match value {
        Val::Array(v) => format!("an int[{}]", v.len()),
        Val::Str(_) => "a string".into(),
        _ => "an int".into(),
    }
}
