//! OSL closures while lowering: a closure call becomes a lobe list (`shadenet_graph`'s
//! `closure` module: each OSL closure mapped onto the lobe that has its formula), closure
//! arithmetic (`+`, `*` by a float or a color) becomes list operations, and a closure chosen
//! by a condition becomes both lists weighted by it ([`Lower::merge`]).
//!
//! The mapping (docs/languages.md has the table): `diffuse` is the Oren–Nayar lobe at
//! roughness 0 (Lambert); `oren_nayar(N, σ)` that lobe; `phong(N, e)` the normalized Phong
//! lobe; `microfacet("ggx", N, α, η, refr)` and `reflection(N, η)` / `refraction(N, η)` the
//! GGX dielectric (smooth ones at the lobes' minimum roughness); `reflection(N)` a white
//! mirror; `translucent` and `transparent` the transmission lobes; `emission()` radiance
//! equal to its weight; the MaterialX closures of OSL 1.12+ their pbrlib lobes. It owns
//! this mapping; it must not hold lobe formulas.

use super::{Lower, Ty, Val};
use crate::source::Span;
use shadenet_graph::Type;
use shadenet_graph::closure::{Closure, Lobe, LobeKind, ScatterMode, ThinFilm};
use shadenet_graph::ir::{Builder, Stream, Value};
use shadenet_graph::mtlx::atoms_closure::{frame_at, view_dir};

/// The closures built, with their signatures (for errors).
const CLOSURES: &[(&str, &str)] = &[
    ("diffuse", "(normal N)"),
    ("oren_nayar", "(normal N, float sigma)"),
    ("phong", "(normal N, float exponent)"),
    (
        "microfacet",
        "(string distribution, normal N, float alpha, float eta, int refract) or (string distribution, normal N, vector U, float xalpha, float yalpha, float eta, int refract)",
    ),
    ("reflection", "(normal N[, float eta])"),
    ("refraction", "(normal N, float eta)"),
    ("translucent", "(normal N)"),
    ("transparent", "()"),
    ("emission", "()"),
    (
        "oren_nayar_diffuse_bsdf",
        "(normal N, color albedo, float roughness)",
    ),
    (
        "burley_diffuse_bsdf",
        "(normal N, color albedo, float roughness)",
    ),
    ("translucent_bsdf", "(normal N, color albedo)"),
    (
        "subsurface_bssrdf",
        "(normal N, color albedo, color radius, float anisotropy) (OSL 1.14) or (normal N, color albedo, float transmission_depth, color transmission_color, float anisotropy)",
    ),
    ("sheen_bsdf", "(normal N, color albedo, float roughness)"),
    (
        "dielectric_bsdf",
        "(normal N, vector U, color reflection_tint, color transmission_tint, float roughness_x, float roughness_y, float ior, string distribution[, \"thinfilm_thickness\", float][, \"thinfilm_ior\", float])",
    ),
    (
        "conductor_bsdf",
        "(normal N, vector U, float roughness_x, float roughness_y, color ior, color extinction, string distribution[, \"thinfilm_thickness\", float][, \"thinfilm_ior\", float])",
    ),
    (
        "generalized_schlick_bsdf",
        "(normal N, vector U, color reflection_tint, color transmission_tint, float roughness_x, float roughness_y, color f0, color f90, float exponent, string distribution[, \"thinfilm_thickness\", float][, \"thinfilm_ior\", float])",
    ),
    ("uniform_edf", "(color emittance)"),
    ("layer", "(closure color top, closure color base)"),
];

/// OSL closures we know of but have not built, and why.
const UNBUILT: &[(&str, &str)] = &[
    ("ward", "the Ward lobe is not built"),
    ("background", "background shaders are not built"),
    ("holdout", "holdouts are not built"),
    ("debug", "debug closures are not built"),
    ("chiang_hair_bsdf", "no hair BSDF yet"),
    ("anisotropic_vdf", "volumes are not built"),
    ("medium_vdf", "volumes are not built"),
];

/// The names of the closures (built or not), for "did you mean".
pub(crate) fn names() -> impl Iterator<Item = &'static str> {
    CLOSURES
        .iter()
        .map(|(n, _)| *n)
        .chain(UNBUILT.iter().map(|(n, _)| *n))
}

impl<'a> Lower<'a> {
    /// A closure call, or `None` when `name` is not one of OSL's closures.
    pub(crate) fn closure_call(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
        span: Span,
    ) -> Option<Val> {
        if let Some((_, why)) = UNBUILT.iter().find(|(n, _)| *n == name) {
            self.error(format!("`{name}`: {why} yet"), span, "not built yet");
            return Some(Val::Closure(Box::default()));
        }
        if name == "mix" {
            return self.closure_mix(b, args);
        }
        let (_, sig) = CLOSURES.iter().find(|(n, _)| *n == name)?;
        let c = self.build_closure(b, name, args).unwrap_or_else(|| {
            let got: Vec<&str> = args.iter().map(|(v, _)| v.type_name()).collect();
            self.error(
                format!(
                    "`{name}` does not take ({}): it takes {sig}",
                    got.join(", ")
                ),
                span,
                "wrong arguments",
            );
            Closure::default()
        });
        Some(Val::Closure(Box::new(c)))
    }

    /// stdosl.h's `mix(closure x, closure y, float a)`: `x (1 − a) + y a`; `None` (the
    /// ordinary `mix`) unless both `x` and `y` are closures.
    fn closure_mix(&mut self, b: &mut Builder, args: &[(Val, Span)]) -> Option<Val> {
        let [(Val::Closure(x), _), (Val::Closure(y), _), (a, _)] = args else {
            return None;
        };
        let a = weight(b, a)?;
        let one = b.float(1.0);
        let one = b.splat_to(b.ty(a), one);
        let keep = b.sub(one, a);
        let xs = x.scaled(b, keep);
        let ys = y.scaled(b, a);
        Some(Val::Closure(Box::new(Closure::add(b, &xs, &ys))))
    }

    /// The lobe list of closure `name` on `args`; `None` when the arguments do not fit.
    fn build_closure(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
    ) -> Option<Closure> {
        use Ty::{Color as C, Float as F, Normal as N, Vector as V};
        let white = b.color([1.0; 3]);
        let zero = b.float(0.0);
        let no_tangent = b.zero(Type::Vec3);
        let lobe = |b: &mut Builder, kind, n, t, component| {
            let frame = frame_at(b, n, t);
            Closure::lobe(Lobe {
                kind,
                weight: white,
                frame,
                component,
                unbuilt: None,
            })
        };
        let c = match name {
            "diffuse" | "oren_nayar" => {
                let (n, sigma) = match name {
                    "diffuse" => (self.operands(b, args, &[N])?[0], zero),
                    _ => {
                        let v = self.operands(b, args, &[N, F])?;
                        (v[0], v[1])
                    }
                };
                let kind = LobeKind::OrenNayar {
                    color: white,
                    roughness: sigma,
                    energy_compensation: false,
                };
                lobe(b, kind, n, no_tangent, "diffuse")
            }
            "phong" => {
                let v = self.operands(b, args, &[N, F])?;
                let kind = LobeKind::Phong {
                    color: white,
                    exponent: v[1],
                };
                lobe(b, kind, v[0], no_tangent, "specular")
            }
            "microfacet" => self.microfacet(b, args)?,
            "reflection" | "refraction" => {
                let (n, eta) = match (name, args.len()) {
                    ("reflection", 1) => (self.operands(b, args, &[N])?[0], None),
                    _ => {
                        let v = self.operands(b, args, &[N, F])?;
                        (v[0], Some(v[1]))
                    }
                };
                let smooth = b.zero(Type::Vec2);
                let (kind, component) = match eta {
                    // A perfect mirror: Schlick with F0 = F90 = 1 is white at every angle.
                    None => (
                        LobeKind::GeneralizedSchlick {
                            color0: white,
                            color82: white,
                            color90: white,
                            exponent: b.float(5.0),
                            roughness: smooth,
                            scatter_mode: ScatterMode::R,
                            thin_film: None,
                        },
                        "specular",
                    ),
                    Some(eta) => {
                        let mode = if name == "reflection" {
                            ScatterMode::R
                        } else {
                            ScatterMode::T
                        };
                        return Some(osl_dielectric(b, (n, no_tangent), eta, smooth, mode));
                    }
                };
                lobe(b, kind, n, no_tangent, component)
            }
            "translucent" | "translucent_bsdf" => {
                let (n, color) = if name == "translucent" {
                    (self.operands(b, args, &[N])?[0], white)
                } else {
                    let v = self.operands(b, args, &[N, C])?;
                    (v[0], v[1])
                };
                lobe(
                    b,
                    LobeKind::Translucent { color },
                    n,
                    no_tangent,
                    "transmission",
                )
            }
            "subsurface_bssrdf" => self.subsurface(b, args)?,
            "transparent" => {
                self.operands(b, args, &[])?;
                // Straight through: a smooth dielectric of index 1 that only transmits.
                let one = b.float(1.0);
                let smooth = b.zero(Type::Vec2);
                let (kind, component) = dielectric(white, one, smooth, ScatterMode::T, None);
                let n = b.stream(Stream::N);
                lobe(b, kind, n, no_tangent, component)
            }
            "emission" => {
                self.operands(b, args, &[])?;
                Closure::emitter(white)
            }
            "uniform_edf" => Closure::emitter(self.operands(b, args, &[C])?[0]),
            "oren_nayar_diffuse_bsdf" | "burley_diffuse_bsdf" | "sheen_bsdf" => {
                let v = self.operands(b, args, &[N, C, F])?;
                let (color, roughness) = (v[1], v[2]);
                let (kind, component) = match name {
                    "oren_nayar_diffuse_bsdf" => (
                        LobeKind::OrenNayar {
                            color,
                            roughness,
                            energy_compensation: false,
                        },
                        "diffuse",
                    ),
                    "burley_diffuse_bsdf" => (LobeKind::Burley { color, roughness }, "diffuse"),
                    _ => (LobeKind::Sheen { color, roughness }, "sheen"),
                };
                lobe(b, kind, v[0], no_tangent, component)
            }
            "dielectric_bsdf" | "generalized_schlick_bsdf" => self.mx_specular(b, name, args)?,
            "conductor_bsdf" => {
                let (v, thin_film) =
                    self.operands_and_distribution(b, args, &[N, V, F, F, C, C])?;
                let roughness = b.construct(Type::Vec2, &[v[2], v[3]]);
                let kind = LobeKind::Conductor {
                    ior: v[4],
                    extinction: v[5],
                    roughness,
                    thin_film,
                };
                lobe(b, kind, v[0], v[1], "specular")
            }
            "layer" => match args {
                [(Val::Closure(top), _), (Val::Closure(base), _)] => {
                    let wo = view_dir(b);
                    Closure::layer(b, top, base, wo)
                }
                _ => return None,
            },
            _ => return None,
        };
        Some(c)
    }

    /// `subsurface_bssrdf(N, albedo, radius, anisotropy)` (OSL 1.14) or `(N, albedo,
    /// transmission_depth, transmission_color, anisotropy)`: MaterialX's `subsurface_bsdf`
    /// lobe, Lambertian reflection of the albedo until volumes exist (see
    /// `closure::subsurface`); the radius (before 1.14 `transmission_color`) and the
    /// anisotropy are kept on the lobe as the native atom keeps them.
    fn subsurface(&mut self, b: &mut Builder, args: &[(Val, Span)]) -> Option<Closure> {
        use Ty::{Color as C, Float as F, Normal as N};
        let (n, color, radius, anisotropy) = match args.len() {
            4 => {
                let v = self.operands(b, args, &[N, C, C, F])?;
                (v[0], v[1], v[2], v[3])
            }
            _ => {
                let v = self.operands(b, args, &[N, C, F, C, F])?;
                (v[0], v[1], v[3], v[4])
            }
        };
        let kind = LobeKind::Subsurface {
            color,
            radius,
            anisotropy,
        };
        let no_tangent = b.zero(Type::Vec3);
        let frame = frame_at(b, n, no_tangent);
        let weight = b.color([1.0; 3]);
        Some(Closure::lobe(Lobe {
            kind,
            weight,
            frame,
            component: "diffuse",
            unbuilt: None,
        }))
    }

    /// `microfacet(distribution, N, [U,] α[x, αy], η, refract)`: a GGX dielectric that
    /// reflects (`refract` 0) or transmits (1).
    fn microfacet(&mut self, b: &mut Builder, args: &[(Val, Span)]) -> Option<Closure> {
        use Ty::{Float as F, Int as I, Normal as N, Vector as V};
        let (dist, rest) = args.split_first()?;
        let Val::Str(dist_name) = &dist.0 else {
            return None;
        };
        if dist_name != "ggx" {
            self.error(
                format!("microfacet distribution \"{dist_name}\" is not built (only \"ggx\")"),
                dist.1,
                "not built",
            );
            return Some(Closure::default());
        }
        let (n, u, ax, ay, eta, refr) = match rest.len() {
            4 => {
                let v = self.operands(b, rest, &[N, F, F, I])?;
                (
                    v[0],
                    b.zero(Type::Vec3),
                    v[1],
                    v[1],
                    v[2],
                    (v[3], rest[3].1),
                )
            }
            6 => {
                let v = self.operands(b, rest, &[N, V, F, F, F, I])?;
                (v[0], v[1], v[2], v[3], v[4], (v[5], rest[5].1))
            }
            _ => return None,
        };
        let mode = match shadenet_graph::opt::fold::constant(b.program(), refr.0)
            .as_ref()
            .and_then(super::osl::const_number)
        {
            Some(0.0) => ScatterMode::R,
            Some(1.0) => ScatterMode::T,
            _ => {
                self.error(
                    "microfacet's `refract` must be a constant 0 or 1",
                    refr.1,
                    "not a constant 0 or 1",
                );
                return Some(Closure::default());
            }
        };
        let roughness = b.construct(Type::Vec2, &[ax, ay]);
        Some(osl_dielectric(b, (n, u), eta, roughness, mode))
    }

    /// MaterialX's `dielectric_bsdf` and `generalized_schlick_bsdf` as OSL declares them:
    /// separate reflection and transmission tints become a reflecting lobe and a
    /// transmitting lobe (a tint that is the constant 0 drops its lobe), as MaterialX's
    /// OSL generator maps `scatter_mode` onto the tints.
    fn mx_specular(
        &mut self,
        b: &mut Builder,
        name: &str,
        args: &[(Val, Span)],
    ) -> Option<Closure> {
        use Ty::{Color as C, Float as F, Normal as N, Vector as V};
        let schlick = name == "generalized_schlick_bsdf";
        let tys: &[Ty] = if schlick {
            &[N, V, C, C, F, F, C, C, F]
        } else {
            &[N, V, C, C, F, F, F]
        };
        let (v, thin_film) = self.operands_and_distribution(b, args, tys)?;
        let roughness = b.construct(Type::Vec2, &[v[4], v[5]]);
        let mut out = Closure::default();
        for (tint, mode) in [(v[2], ScatterMode::R), (v[3], ScatterMode::T)] {
            let zero = shadenet_graph::opt::fold::constant(b.program(), tint)
                == Some(shadenet_graph::ConstValue::Color([0.0; 3]));
            if zero {
                continue;
            }
            let (kind, component, weight) = if schlick {
                let kind = LobeKind::GeneralizedSchlick {
                    color0: v[6],
                    color82: b.color([1.0; 3]),
                    color90: v[7],
                    exponent: v[8],
                    roughness,
                    scatter_mode: mode,
                    thin_film,
                };
                (kind, specular_component(mode), tint)
            } else {
                let (kind, component) = dielectric(tint, v[6], roughness, mode, thin_film);
                (kind, component, b.color([1.0; 3]))
            };
            let frame = frame_at(b, v[0], v[1]);
            let lobe = Closure::lobe(Lobe {
                kind,
                weight,
                frame,
                component,
                unbuilt: None,
            });
            out = Closure::add(b, &out, &lobe);
        }
        Some(out)
    }

    /// `args` (all of them) converted to `tys`; `None` when the count or a string differs
    /// (a type mismatch is reported by the conversion).
    fn operands(
        &mut self,
        b: &mut Builder,
        args: &[(Val, Span)],
        tys: &[Ty],
    ) -> Option<Vec<Value>> {
        if args.len() != tys.len() {
            return None;
        }
        let mut out = Vec::with_capacity(tys.len());
        for ((v, at), ty) in args.iter().zip(tys) {
            if !matches!(v, Val::V { .. }) {
                return None;
            }
            match self.coerce(b, v.clone(), *ty, *at) {
                Val::V { v, .. } => out.push(v),
                _ => return None,
            }
        }
        Some(out)
    }

    /// [`Lower::operands`] followed by a distribution name, which must be `"ggx"`, and
    /// OSL's optional keyword arguments of the MaterialX closures (`"thinfilm_thickness",
    /// t, "thinfilm_ior", n`, as MaterialX's OSL generator writes them): the thin film, or
    /// `None` where its thickness is absent or the constant 0. An unknown keyword is an error
    /// naming it.
    fn operands_and_distribution(
        &mut self,
        b: &mut Builder,
        args: &[(Val, Span)],
        tys: &[Ty],
    ) -> Option<(Vec<Value>, Option<ThinFilm>)> {
        let (head, keywords) = args.split_at_checked(tys.len() + 1)?;
        let (last, rest) = head.split_last()?;
        let Val::Str(dist) = &last.0 else {
            return None;
        };
        let v = self.operands(b, rest, tys)?;
        if dist != "ggx" {
            self.error(
                format!("microfacet distribution \"{dist}\" is not built (only \"ggx\")"),
                last.1,
                "not built",
            );
        }
        let film = self.thin_film_keywords(b, keywords)?;
        Some((v, film))
    }

    /// The `"thinfilm_thickness"` and `"thinfilm_ior"` keyword pairs of a MaterialX closure
    /// (defaults 0 and 1.5, MaterialX's); `None` when they are not name–value pairs.
    fn thin_film_keywords(
        &mut self,
        b: &mut Builder,
        keywords: &[(Val, Span)],
    ) -> Option<Option<ThinFilm>> {
        if !keywords.len().is_multiple_of(2) {
            return None;
        }
        let (mut thickness, mut ior) = (None, None);
        for pair in keywords.chunks(2) {
            let Val::Str(key) = &pair[0].0 else {
                return None;
            };
            let slot = match key.as_str() {
                "thinfilm_thickness" => &mut thickness,
                "thinfilm_ior" => &mut ior,
                _ => {
                    self.error(
                        format!(
                            "closure keyword \"{key}\" is not built (built: \"thinfilm_thickness\", \"thinfilm_ior\")"
                        ),
                        pair[0].1,
                        "unknown keyword",
                    );
                    continue;
                }
            };
            *slot = Some(self.operands(b, &pair[1..], &[Ty::Float])?[0]);
        }
        let Some(thickness) = thickness else {
            return Some(None);
        };
        let zero = shadenet_graph::opt::fold::constant(b.program(), thickness)
            == Some(shadenet_graph::ConstValue::Float(0.0));
        let ior = ior.unwrap_or_else(|| b.float(1.5));
        Some((!zero).then_some(ThinFilm { thickness, ior }))
    }

    /// The closure an OSL operator makes of `a` and `c`, where one is a closure: `+` of two
    /// closures, `*` of a closure and a float or color (either order); `None` for anything
    /// else (an error the caller reports).
    pub(crate) fn closure_arith(
        &mut self,
        b: &mut Builder,
        op: crate::ast::BinaryOp,
        a: &Val,
        c: &Val,
    ) -> Option<Closure> {
        use crate::ast::BinaryOp as Op;
        match (op, a, c) {
            (Op::Add, Val::Closure(x), Val::Closure(y)) => Some(Closure::add(b, x, y)),
            (Op::Mul, Val::Closure(x), k) | (Op::Mul, k, Val::Closure(x)) => {
                let k = weight(b, k)?;
                Some(x.scaled(b, k))
            }
            (Op::Div, Val::Closure(x), k) => {
                let k = weight(b, k)?;
                let one = b.float(1.0);
                let one = b.splat_to(b.ty(k), one);
                let r = b.div(one, k);
                Some(x.scaled(b, r))
            }
            _ => None,
        }
    }

    /// The value of a variable after a condition `c` (`vc`: whether it varies) chose
    /// between `then` and `els`: a select for values, both closures weighted by the
    /// condition for closures, arrays and structs part by part; for two different strings
    /// the one a compile-time condition picks, else an error at `at` (strings are
    /// compile-time values).
    pub(crate) fn merge(
        &mut self,
        b: &mut Builder,
        (c, vc): (Value, bool),
        then: Val,
        els: Val,
        at: Span,
    ) -> Val {
        match (then, els) {
            (
                Val::V {
                    v: t,
                    ty,
                    varying: vt,
                },
                Val::V {
                    v: e, varying: ve, ..
                },
            ) => Val::V {
                v: b.select(c, t, e),
                ty,
                varying: vc || vt || ve,
            },
            (Val::Closure(t), Val::Closure(e)) => {
                let (one, zero) = (b.float(1.0), b.float(0.0));
                let k = b.select(c, one, zero);
                Val::Closure(Box::new(Closure::mix(b, &e, &t, k)))
            }
            (Val::Array(t), Val::Array(e)) if t.len() == e.len() => Val::Array(
                t.into_iter()
                    .zip(e)
                    .map(|(t, e)| self.merge(b, (c, vc), t, e, at))
                    .collect(),
            ),
            (Val::Struct(n, t), Val::Struct(_, e)) if t.len() == e.len() => Val::Struct(
                n,
                t.into_iter()
                    .zip(e)
                    .map(|((f, t), (_, e))| (f, self.merge(b, (c, vc), t, e, at)))
                    .collect(),
            ),
            (Val::Str(t), Val::Str(e)) if t == e => Val::Str(t),
            (Val::Str(t), Val::Str(e)) => match super::unroll::known(b.program(), c) {
                Some(true) => Val::Str(t),
                Some(false) => Val::Str(e),
                None => {
                    self.error(
                        format!(
                            "a string is \"{t}\" or \"{e}\" by a condition known only while shading (strings are compile-time values)"
                        ),
                        at,
                        "assigned under this condition",
                    );
                    Val::Str(t)
                }
            },
            (t, _) => t,
        }
    }
}

/// OSL's dielectric closures (`reflection`, `refraction`, `microfacet`): a white GGX
/// dielectric lobe in the frame of `(N, U)`. OSL's `eta` is the index seen from the
/// viewer's side (a shader passes `1/ior` where `backfacing()`), our lobe's the material's
/// (it turns itself around inside), so seen from inside the index is `1/eta`.
fn osl_dielectric(
    b: &mut Builder,
    (n, u): (Value, Value),
    eta: Value,
    roughness: Value,
    mode: ScatterMode,
) -> Closure {
    let frame = frame_at(b, n, u);
    let one = b.float(1.0);
    let inv = b.div(one, eta);
    let ior = b.select(frame.inside, inv, eta);
    let white = b.color([1.0; 3]);
    let (kind, component) = dielectric(white, ior, roughness, mode, None);
    Closure::lobe(Lobe {
        kind,
        weight: white,
        frame,
        component,
        unbuilt: None,
    })
}

/// The IR value of a closure weight: a float or a color (an int converted to float);
/// `None` for anything else.
fn weight(b: &mut Builder, v: &Val) -> Option<Value> {
    match v {
        Val::V {
            v,
            ty: Ty::Float | Ty::Color,
            ..
        } => Some(*v),
        Val::V { v, ty: Ty::Int, .. } => Some(b.convert(Type::Float, *v)),
        _ => None,
    }
}

/// A dielectric lobe of `tint`, index `ior`, `roughness` (vec2), `mode` and thin film, with
/// its render component.
fn dielectric(
    tint: Value,
    ior: Value,
    roughness: Value,
    mode: ScatterMode,
    thin_film: Option<ThinFilm>,
) -> (LobeKind, &'static str) {
    (
        LobeKind::Dielectric {
            tint,
            ior,
            roughness,
            scatter_mode: mode,
            thin_film,
        },
        specular_component(mode),
    )
}

/// `specular` for reflection, `transmission` for lobes that transmit (as the MaterialX
/// atoms do).
fn specular_component(mode: ScatterMode) -> &'static str {
    match mode {
        ScatterMode::R => "specular",
        ScatterMode::T | ScatterMode::RT => "transmission",
    }
}
