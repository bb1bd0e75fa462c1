//! RSL `light` shaders: the program a scene light evaluates per light sample. The shaded
//! point `Ps` is the fragment stream `P` (it differs per sample, so it cannot be a
//! parameter: parameters are uniform, folded and hoisted by the optimizer; a stream is what
//! the IR reads per fragment), the instance parameters are the program's, and the outputs
//! say where the light is and what it sends:
//!
//! - `illuminate(from [, axis, angle]) body`: `L` is `Ps - from` (light to surface,
//!   unnormalised) in the body; outputs `Cl` (color) and [`OUT_FROM`] (the light's
//!   position). Outside the cone (`angle` from `axis`, when given) the body does not run and
//!   `Cl` is black.
//! - `solar(axis, angle) body`: a directional light, `L` is `axis` in the body; outputs `Cl`
//!   and [`OUT_AXIS`] (the direction light travels). Only `angle` 0 is built: a spread of
//!   directions would be an area light.
//! - neither: an ambient light; the only output is `Cl`, which the renderer adds to
//!   `ambient()`.
//!
//! One `illuminate` or `solar` per shader, at the top level of its body (statements before
//! and after it run as in a surface shader). It owns only the light shader's rules; the
//! outputs' contract is `shadenet_graph::nodes::shader_light`'s, sampling the runtime's.

use super::{Lower, Ty, Val, Var, const_eval};
use crate::ast::{self, Stmt, StmtKind};
use crate::source::Span;
use shadenet_graph::Type;
use shadenet_graph::ir::{BinOp, Builder, Stream, UnOp, Value};
use std::collections::HashMap;

pub use shadenet_graph::nodes::shader_light::{OUT_AXIS, OUT_CL, OUT_FROM};

/// Where the light of an `illuminate` or `solar` statement comes from.
struct Placed {
    /// [`OUT_FROM`] or [`OUT_AXIS`].
    output: &'static str,
    /// The position or axis.
    value: Value,
    /// The statement (for a second one's error).
    span: Span,
}

impl<'a> Lower<'a> {
    /// A light shader: its globals, parameters, body and outputs (see the module header).
    pub(crate) fn light(&mut self, b: &mut Builder, shader: &'a ast::ShaderDef) {
        self.light_globals(b);
        for p in &shader.params {
            self.param(b, p);
        }
        self.scopes.push(HashMap::new());
        let mut placed: Option<Placed> = None;
        for s in &shader.body.stmts {
            if self.stopped() {
                break;
            }
            if !matches!(s.kind, StmtKind::Illuminate { .. } | StmtKind::Solar { .. }) {
                self.stmt(b, s);
                continue;
            }
            if let Some(first) = &placed {
                let d = crate::diag::Diagnostic::error(
                    "a light shader with more than one `illuminate` or `solar` is not built: one light per shader",
                    s.span,
                    "a second one",
                )
                .with_secondary(first.span, "the first");
                self.diags.push(d);
                continue;
            }
            placed = self.emission(b, s);
        }
        self.scopes.pop();
        let cl = match self.lookup("Cl").map(|v| v.val.clone()) {
            Some(Val::V { v, .. }) => v,
            _ => b.zero(Type::Color),
        };
        b.output(OUT_CL, None, cl);
        if let Some(p) = placed {
            b.output(p.output, None, p.value);
        }
    }

    /// A light shader's globals: `Ps` (the shaded point), `Cl` (black until assigned), `L`
    /// (zero outside `illuminate`/`solar`), `PI`.
    fn light_globals(&mut self, b: &mut Builder) {
        let ps = b.stream(Stream::P);
        let black = b.color([0.0; 3]);
        let zero = b.zero(Type::Vec3);
        let pi = b.float(std::f64::consts::PI);
        for (name, v, ty, varying) in [
            ("Ps", ps, Ty::Point, true),
            ("Cl", black, Ty::Color, false),
            ("L", zero, Ty::Vector, false),
            ("PI", pi, Ty::Float, false),
        ] {
            self.scopes[0].insert(
                name.to_string(),
                Var {
                    val: Val::V { v, ty, varying },
                    uniform: false,
                    decl: None,
                },
            );
        }
    }

    /// One `illuminate` or `solar` statement: binds `L`, runs the body (inside the cone),
    /// and says where the light is.
    fn emission(&mut self, b: &mut Builder, s: &'a Stmt) -> Option<Placed> {
        let (args, body, solar) = match &s.kind {
            StmtKind::Illuminate { args, body } => (args, body, false),
            StmtKind::Solar { args, body } => (args, body, true),
            _ => return None,
        };
        let triple =
            |me: &mut Self, b: &mut Builder, e: &'a ast::Expr, ty: Ty| match me.expr_as(b, e, ty) {
                Val::V { v, .. } => Some(v),
                _ => None,
            };
        let (output, value, l, cone) = if solar {
            let [axis, angle] = args.as_slice() else {
                self.error(
                    "solar takes (axis, angle): solar() without an axis (light from every direction) is not built; use the scene's environment light",
                    s.span,
                    "here",
                );
                return None;
            };
            if !matches!(const_eval(angle, Ty::Float), Some(shadenet_graph::ConstValue::Float(a)) if a == 0.0)
            {
                self.error(
                    "solar with a spread angle is not built: only solar(axis, 0), a directional light",
                    angle.span,
                    "not 0",
                );
                return None;
            }
            let axis = triple(self, b, axis, Ty::Vector)?;
            (OUT_AXIS, axis, axis, None)
        } else {
            let (from, cone) = match args.as_slice() {
                [from] => (from, None),
                [from, axis, angle] => (from, Some((axis, angle))),
                _ => {
                    self.error(
                        "illuminate takes (from) or (from, axis, angle)",
                        s.span,
                        "here",
                    );
                    return None;
                }
            };
            let from = triple(self, b, from, Ty::Point)?;
            let ps = b.stream(Stream::P);
            let l = b.sub(ps, from);
            let cone = match cone {
                Some((axis, angle)) => {
                    let axis = triple(self, b, axis, Ty::Vector)?;
                    let angle = triple(self, b, angle, Ty::Float)?;
                    Some((axis, angle))
                }
                None => None,
            };
            (OUT_FROM, from, l, cone)
        };
        // Cl is black where the body does not run (outside the cone).
        let black = b.color([0.0; 3]);
        self.rebind(
            &ast::Ident {
                name: "Cl".into(),
                span: s.span,
            },
            Val::V {
                v: black,
                ty: Ty::Color,
                varying: false,
            },
            false,
            s.span,
        );
        let mut scope = HashMap::new();
        scope.insert(
            "L".to_string(),
            Var {
                val: Val::V {
                    v: l,
                    ty: Ty::Vector,
                    varying: true,
                },
                uniform: false,
                decl: None,
            },
        );
        self.scopes.push(scope);
        match cone {
            None => self.stmt(b, body),
            Some((axis, angle)) => {
                let inside = in_cone(b, l, axis, angle);
                let names = self.assigned_outer(&[&**body]);
                self.guarded(b, inside, true, &names, &mut |me, b| me.stmt(b, body));
            }
        }
        self.scopes.pop();
        Some(Placed {
            output,
            value,
            span: s.span,
        })
    }
}

/// Whether `l` lies within `angle` of `axis`: `dot(normalize(l), normalize(axis)) >=
/// cos(angle)`.
fn in_cone(b: &mut Builder, l: Value, axis: Value, angle: Value) -> Value {
    let nl = b.normalize(l);
    let na = b.normalize(axis);
    let d = b.dot(nl, na);
    let c = b.unary(UnOp::Cos, angle);
    b.binary(BinOp::Ge, d, c)
}
