//! OSL's `getattribute(name, output value)`: which names a shader can read here and how.
//! It owns these rules:
//!
//! - A name is a **geometry attribute** (a primvar: vertex colours, extra uv sets, any
//!   per-vertex float data of the mesh), read through the IR's [`Op::Attribute`] (the value,
//!   with the output's current value as the default, so a name the geometry lacks leaves
//!   the output as it was) and [`Op::AttributeFound`] (the call's result: 1 where the
//!   geometry has it, else 0) — the same ops MaterialX's native `geompropvalue` lowers to.
//!   The renderer resolves names against each mesh, so a name no mesh has is not an error:
//!   the call returns 0 and leaves the output, as OSL's renderers do for an unknown name.
//! - `"color"` reads the geometry's first colour set, `COLOR_0` (MaterialX's OSL `geomcolor`
//!   reads `"color"`; our meshes name colour set n `COLOR_n`, glTF's name, as the native
//!   `geomcolor` does).
//! - `"time"` is the shading context's time (the fragment's, the `time` global's), always
//!   found.
//! - Outputs: `float`, `int` (the attribute's float truncated toward zero, as MaterialX's
//!   integer `geompropvalue` converts), the triples (`color`, `point`, `vector`, `normal`),
//!   and arrays of 1 to 4 floats (read as a vector of that width). A `string` output is
//!   never found (geometry attributes are floats; the output keeps its value). Other
//!   outputs, and the object and array-element forms, are errors naming the call.
//! - Names are strings, which are compile-time values here: a name is always known when
//!   the shader compiles.
//!
//! [`Op::Attribute`]: shadenet_graph::ir::Op::Attribute
//! [`Op::AttributeFound`]: shadenet_graph::ir::Op::AttributeFound

use super::{Lower, Ty, Val};
use crate::ast::Expr;
use crate::source::Span;
use shadenet_graph::Type;
use shadenet_graph::ir::{Builder, Stream, Value};

/// The geometry attribute a `getattribute` name reads, where it is not the name itself.
pub(crate) fn geometry_name(name: &str) -> String {
    match name {
        "color" => shadenet_graph::mtlx::atoms_geom::color_set_name(0),
        _ => name.to_string(),
    }
}

impl<'a> Lower<'a> {
    /// `getattribute(name, value)` with the arguments' values `vals` and expressions
    /// `args` (the last is the output): the call's int result.
    pub(crate) fn getattribute(
        &mut self,
        b: &mut Builder,
        vals: Vec<(Val, Span)>,
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let (name, old, target) = match (vals.as_slice(), args) {
            ([(Val::Str(name), _), (old, _)], [_, target]) => (name.clone(), old.clone(), target),
            ([(Val::Str(_), _), (Val::Str(_), _), _], _) => {
                return self.getattribute_error(
                    b,
                    "`getattribute` of a named object is not built: a shader reads the attributes of the geometry it shades",
                    span,
                );
            }
            ([(Val::Str(_), _), (Val::V { ty: Ty::Int, .. }, _), _], _) => {
                return self.getattribute_error(
                    b,
                    "`getattribute(name, index, value)` (one element of an array attribute) is not built: read the whole array",
                    span,
                );
            }
            _ => {
                return self.getattribute_error(
                    b,
                    "`getattribute` takes (string name, output value)",
                    span,
                );
            }
        };
        let found = if name == "time" {
            let t = Val::V {
                v: b.stream(Stream::Time),
                ty: Ty::Float,
                varying: true,
            };
            let ty = match &old {
                Val::V { ty, .. } => *ty,
                _ => Ty::Float,
            };
            let t = self.coerce(b, t, ty, span);
            self.store_output_arg(b, target, t, (2, "getattribute"));
            b.boolean(true)
        } else {
            match self.read_attribute(b, &geometry_name(&name), old) {
                Ok(Some((value, found))) => {
                    self.store_output_arg(b, target, value, (2, "getattribute"));
                    found
                }
                Ok(None) => b.boolean(false),
                Err(why) => return self.getattribute_error(b, &why, target.span),
            }
        };
        let (one, zero) = (b.int(1), b.int(0));
        Val::V {
            v: b.select(found, one, zero),
            ty: Ty::Int,
            varying: true,
        }
    }

    /// Geometry attribute `name` read into an output holding `old`: the output's new value
    /// (`old` where the geometry lacks it) and whether it was found; `None` for a string
    /// output (never found); an error for an output no attribute fits.
    fn read_attribute(
        &mut self,
        b: &mut Builder,
        name: &str,
        old: Val,
    ) -> Result<Option<(Val, Value)>, String> {
        let plain = |v: Value, ty: Ty| Val::V {
            v,
            ty,
            varying: true,
        };
        match old {
            Val::Str(_) => Ok(None),
            Val::V { v, ty: Ty::Int, .. } => {
                let d = b.convert(Type::Float, v);
                let got = b.attribute(name, d);
                let found = b.attribute_found(name, Type::Float);
                // Where it is missing the int keeps its own value (not a float round trip).
                let got = b.convert(Type::Int, got);
                Ok(Some((plain(b.select(found, got, v), Ty::Int), found)))
            }
            Val::V { v, ty, .. } if ty == Ty::Float || ty.is_triple() => {
                let got = b.attribute(name, v);
                let found = b.attribute_found(name, ty.ir());
                Ok(Some((plain(got, ty), found)))
            }
            Val::Array(elems)
                if (1..=4).contains(&elems.len())
                    && elems
                        .iter()
                        .all(|e| matches!(e, Val::V { ty: Ty::Float, .. })) =>
            {
                let parts: Vec<Value> = elems
                    .iter()
                    .filter_map(|e| match e {
                        Val::V { v, .. } => Some(*v),
                        _ => None,
                    })
                    .collect();
                let Some(ty) = Type::float_vec(parts.len()) else {
                    return Err(format!("no attribute type of {} floats", parts.len()));
                };
                let d = if parts.len() == 1 {
                    parts[0]
                } else {
                    b.construct(ty, &parts)
                };
                let got = b.attribute(name, d);
                let found = b.attribute_found(name, ty);
                let elems = (0..parts.len())
                    .map(|k| {
                        let x = if parts.len() == 1 {
                            got
                        } else {
                            b.extract(got, k)
                        };
                        plain(x, Ty::Float)
                    })
                    .collect();
                Ok(Some((Val::Array(elems), found)))
            }
            other => Err(format!(
                "`getattribute` reads geometry attributes into a float, an int, a color, point, vector or normal, or an array of 1 to 4 floats; not into {}",
                super::an(other.type_name())
            )),
        }
    }

    /// Reports `why` at `span`; the call's result is then an int poison.
    fn getattribute_error(&mut self, b: &mut Builder, why: &str, span: Span) -> Val {
        self.error(why.to_string(), span, "getattribute");
        Self::poison(b, Ty::Int)
    }
}
