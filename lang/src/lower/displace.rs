//! `displacement` shaders (RSL and OSL): they move `P` and set `N`; we shade with the
//! displaced normal (bump mapping), not moved geometry. A displacement shader alone compiles
//! to a program whose outputs are the displaced `P` and `N`; attached to a surface shader
//! ([`compile_displaced`]) it is lowered first into the same program, and the surface reads
//! its `N` wherever it reads the shading normal (the IR's stream override), so the
//! optimizer, every back end and the closures' lobes see one program.
//!
//! The normal: an OSL displacement shader that moves `P` and leaves `N` alone gets the
//! renderer's, the normal of the displaced surface — `normalize(calculatenormal(P))` turned to the side of
//! the undisplaced `N` — as OSL's renderers recompute it; one that assigns `N` keeps its
//! own, as does every RSL shader (RenderMan's shaders set `N = calculatenormal(P)`
//! themselves; an RSL shader that does not keeps the original normal, as there). Owns
//! these rules; the stream override is the builder's.

use super::{Lower, Val};
use crate::ast::{self, Item, ShaderKind};
use crate::diag::{Diagnostic, Diagnostics};
use crate::{Dialect, Parsed};
use shadenet_graph::Type;
use shadenet_graph::ir::{BinOp, Builder, Program, Stream, UnOp, Value};

impl<'a> Lower<'a> {
    /// Lowers displacement shader `shader` (globals, parameters, body): the displaced `P`
    /// and the normal to shade with, by the rules above.
    pub(crate) fn displacement(
        &mut self,
        b: &mut Builder,
        shader: &'a ast::ShaderDef,
    ) -> (Value, Value) {
        let n0 = b.stream(Stream::N);
        let p0 = b.stream(Stream::P);
        let stmts: Vec<&'a ast::Stmt> = shader.body.stmts.iter().collect();
        let assigned = self.assigned_places(&stmts);
        let sets = |name: &str| assigned.iter().any(|v| v.name == name);
        let (sets_p, sets_n) = (sets("P"), sets("N"));
        if self.dialect == Dialect::Osl {
            self.osl_layer(b, shader, Val::Closure(Box::default()));
        } else {
            self.surface_body(b, shader);
        }
        let read = |me: &Self, name: &str, default: Value| match me.lookup(name) {
            Some(super::Var {
                val: Val::V { v, .. },
                ..
            }) => *v,
            _ => default,
        };
        let (p, n) = (read(self, "P", p0), read(self, "N", n0));
        let p = b.retype(Type::Vec3, p);
        let n = b.retype(Type::Vec3, n);
        if self.dialect == Dialect::Rsl || sets_n || !sets_p {
            return (p, n);
        }
        (p, displaced_normal(b, p, n0))
    }
}

/// `normalize(calculatenormal(p))` (OSL's: `Dx(p) × Dy(p)`, turned as `calculatenormal`
/// turns it) on the side of `n0`.
fn displaced_normal(b: &mut Builder, p: Value, n0: Value) -> Value {
    let Some([dx, dy]) = b.derivs(p) else {
        // No derivatives (no ray differentials reach P): the undisplaced normal.
        return n0;
    };
    let c = b.binary(BinOp::Cross, dx, dy);
    let n = b.normalize(c);
    let d = b.dot(n, n0);
    let zero = b.float(0.0);
    let away = b.binary(BinOp::Lt, d, zero);
    let flipped = b.unary(UnOp::Neg, n);
    let n = b.select(away, flipped, n);
    // A degenerate cross product (no footprint) normalizes to zero: keep the original.
    let len = b.unary(UnOp::Length, n);
    let none = b.binary(BinOp::Eq, len, zero);
    b.select(none, n0, n)
}

/// The first shader of `parsed`, which must be of one of `kinds` (`what` names them).
fn first_shader<'p>(
    parsed: &'p Parsed,
    kinds: &[ShaderKind],
    what: &str,
) -> Result<&'p ast::ShaderDef, Diagnostics> {
    let shader = parsed.file.items.iter().find_map(|i| match i {
        Item::Shader(s) => Some(s),
        _ => None,
    });
    match shader {
        Some(s) if kinds.contains(&s.kind) => Ok(s),
        Some(s) => Err(Diagnostic::error(
            format!(
                "this is a {} shader: {what} is needed here",
                super::kind_name(s.kind)
            ),
            s.kind_span,
            "this shader",
        )
        .into()),
        None => Err(Diagnostic::error_nowhere("the file defines no shader").into()),
    }
}

/// Compiles the surface shader of `surface` (its first: an RSL `surface`, an OSL `surface`
/// or `shader`) with the displacement shader of `displacement` (its first) lowered before
/// it: one program, named after the surface, that shades with the displaced normal; the
/// displacement's parameters are the program's `displacement.NAME`.
pub fn compile_displaced(surface: &Parsed, displacement: &Parsed) -> Result<Program, Diagnostics> {
    crate::on_big_stack(|| compile_displaced_here(surface, displacement))
}

fn compile_displaced_here(surface: &Parsed, displacement: &Parsed) -> Result<Program, Diagnostics> {
    let s = first_shader(
        surface,
        &[ShaderKind::Surface, ShaderKind::Shader],
        "a surface shader",
    )?;
    let d = first_shader(
        displacement,
        &[ShaderKind::Displacement],
        "a displacement shader",
    )?;
    if super::messages::calls_setmessage(surface) || super::messages::calls_setmessage(displacement)
    {
        return Err(Diagnostic::error(
            "messages (setmessage) between a displacement shader and its surface are not built",
            d.kind_span,
            "not built yet",
        )
        .into());
    }
    let mut b = Builder::new(&s.name.name);
    let mut dl = Lower::new(displacement);
    dl.prefix = "displacement.".into();
    let (_, n) = dl.displacement(&mut b, d);
    let mut diags = dl.diags;
    let n = b.retype(Type::Vec3, n);
    b.push_overrides(&[(Stream::N, n)]);
    let mut sl = Lower::new(surface);
    match surface.dialect {
        Dialect::Osl => sl.osl_shader(&mut b, s),
        Dialect::Rsl => sl.surface(&mut b, s),
    }
    b.pop_overrides(1);
    diags.0.extend(sl.diags.0);
    if diags.has_errors() {
        return Err(diags);
    }
    super::finish(b, s)
}
