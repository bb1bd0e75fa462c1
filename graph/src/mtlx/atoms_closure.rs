//! The closure atoms of MaterialX's pbrlib: BSDF and EDF nodes become lobe lists
//! ([`crate::closure`]), `mix`/`add`/`multiply`/`layer` of closures act on the lists,
//! `surface` and `surfacematerial` carry them to the material output, where the surface
//! lowering ([`crate::closure::shade`]) turns them into light.
//!
//! This module owns which pbrlib node makes which lobe and how its inputs map onto the
//! lobe's parameters; it must not hold lobe formulas (the lobe files do) nor the light loop.

use crate::closure::{Closure, Frame, Lobe, LobeKind, ScatterMode, ThinFilm};
use crate::ir::{Builder, Stream, UnOp, Value};
use crate::nodes::{LowVal, LowerFn, NodeInputs};
use crate::types::Type;

type Out = Result<Vec<LowVal>, String>;

/// The closure atoms: node category → lowering (for nodedefs whose output is a closure).
const CLOSURE_ATOMS: &[(&str, LowerFn)] = &[
    ("oren_nayar_diffuse_bsdf", oren_nayar),
    ("burley_diffuse_bsdf", burley),
    ("translucent_bsdf", translucent),
    ("sheen_bsdf", sheen),
    ("subsurface_bsdf", subsurface),
    ("dielectric_bsdf", dielectric),
    ("conductor_bsdf", conductor),
    ("generalized_schlick_bsdf", generalized_schlick),
    ("uniform_edf", uniform_edf),
    ("absorption_vdf", medium),
    ("anisotropic_vdf", medium),
    ("generalized_schlick_edf", schlick_edf),
    ("surface", surface),
    ("surface_unlit", surface_unlit),
    ("surfacematerial", surfacematerial),
    ("mix", mix),
    ("add", add),
    ("multiply", multiply),
    ("layer", layer),
    ("dot", dot),
];

/// The lowering of a closure-typed atom nodedef (its node category), if there is one.
pub fn lowering(node: &str) -> Option<LowerFn> {
    CLOSURE_ATOMS
        .iter()
        .find(|(n, _)| *n == node)
        .map(|(_, f)| *f)
}

/// Why a closure nodedef has no lowering (for coverage and errors).
pub fn missing_reason(node: &str) -> &'static str {
    match node {
        "volume" | "volumematerial" => "no volumes yet (volume shaders)",
        "displacement" => "no displacement yet",
        "light" => "light shaders are not built: lights come from the scene",
        "chiang_hair_bsdf" => "no hair BSDF yet",
        "conical_edf" | "measured_edf" => {
            "only uniform_edf and generalized_schlick_edf emission are built"
        }
        _ => "no lowering in the closure atom table yet",
    }
}

fn one(v: LowVal) -> Out {
    Ok(vec![v])
}

/// The unit direction towards the viewer, `−normalize(I)` (world).
pub fn view_dir(b: &mut Builder) -> Value {
    let i = b.stream(Stream::I);
    let i = b.normalize(i);
    b.unary(UnOp::Neg, i)
}

/// The frame of a BSDF node from its `normal` and (where it has one) `tangent` inputs.
fn frame(b: &mut Builder, inp: &NodeInputs) -> Frame {
    let n = inp.get("normal");
    let has_t = inp.def.input("tangent").is_some();
    let t = if has_t {
        inp.get("tangent")
    } else {
        b.zero(Type::Vec3)
    };
    frame_at(b, n, t)
}

/// The frame of normal `n` and tangent `t` (zero: any), its side from the geometric normal.
pub fn frame_at(b: &mut Builder, n: Value, t: Value) -> Frame {
    let wo = view_dir(b);
    let mut f = Frame::new(b, n, t, wo);
    // The renderer's `N` already faces the viewer; which side of the material the viewer
    // is on comes from the geometric normal, which points out of closed meshes (as for the
    // Maya surfaces' refraction).
    let ng = b.stream(Stream::Ng);
    let d = b.dot(ng, wo);
    let zero = b.float(0.0);
    f.inside = b.binary(crate::ir::BinOp::Lt, d, zero);
    f
}

/// A one-lobe closure weighted by the node's `weight` input.
fn lobe(b: &mut Builder, inp: &NodeInputs, kind: LobeKind, component: &'static str) -> Out {
    unbuilt_lobe(b, inp, kind, component, None)
}

/// [`lobe`] for a node asking for what no lobe models (`unbuilt`, the reason): it must
/// specialize away ([`crate::closure::Lobe::unbuilt`]).
fn unbuilt_lobe(
    b: &mut Builder,
    inp: &NodeInputs,
    kind: LobeKind,
    component: &'static str,
    unbuilt: Option<String>,
) -> Out {
    let w = inp.get("weight");
    let weight = b.splat(Type::Color, w);
    let frame = frame(b, inp);
    let c = Closure::lobe(Lobe {
        kind,
        weight,
        frame,
        component,
        unbuilt: unbuilt.map(|why| format!("`{}`: {why}", inp.node)),
    });
    one(LowVal::closure(b, c))
}

/// A boolean input's value where it is a compile-time constant of the builder (a literal
/// or a default), else `None`.
fn const_bool(b: &Builder, inp: &NodeInputs, port: &str) -> Option<bool> {
    use crate::ir::Op;
    use crate::types::ConstValue;
    let v = inp.get(port);
    let p = b.program();
    match &p.exprs[v.index()].op {
        Op::Const(ConstValue::Bool(x)) => Some(*x),
        Op::Param(i) => match &p.params[*i as usize].default {
            ConstValue::Bool(x) => Some(*x),
            _ => None,
        },
        _ => None,
    }
}

fn oren_nayar(b: &mut Builder, inp: &NodeInputs) -> Out {
    // `energy_compensation` is a uniform: it chooses the formula at compile time (the
    // value the material is compiled with; a later parameter change does not switch it).
    let ec = const_bool(b, inp, "energy_compensation").unwrap_or(false);
    let kind = LobeKind::OrenNayar {
        color: inp.get("color"),
        roughness: inp.get("roughness"),
        energy_compensation: ec,
    };
    lobe(b, inp, kind, "diffuse")
}

fn burley(b: &mut Builder, inp: &NodeInputs) -> Out {
    let kind = LobeKind::Burley {
        color: inp.get("color"),
        roughness: inp.get("roughness"),
    };
    lobe(b, inp, kind, "diffuse")
}

fn translucent(b: &mut Builder, inp: &NodeInputs) -> Out {
    let kind = LobeKind::Translucent {
        color: inp.get("color"),
    };
    lobe(b, inp, kind, "transmission")
}

fn sheen(b: &mut Builder, inp: &NodeInputs) -> Out {
    // Another mode is built as Conty–Kulla and must specialize away (open_pbr_surface's
    // zeltner fuzz has weight 0 by default).
    let unbuilt =
        (inp.def.input("mode").is_some() && inp.string("mode") != "conty_kulla").then(|| {
            format!(
                "sheen mode `{}` is not built yet (only conty_kulla)",
                inp.string("mode")
            )
        });
    let kind = LobeKind::Sheen {
        color: inp.get("color"),
        roughness: inp.get("roughness"),
    };
    unbuilt_lobe(b, inp, kind, "sheen", unbuilt)
}

/// `subsurface_bsdf`: a Lambertian approximation until volumes exist (see the lobe).
fn subsurface(b: &mut Builder, inp: &NodeInputs) -> Out {
    let kind = LobeKind::Subsurface {
        color: inp.get("color"),
        radius: inp.get("radius"),
        anisotropy: inp.get("anisotropy"),
    };
    lobe(b, inp, kind, "diffuse")
}

/// The thin film of a GGX lobe: `None` where the nodedef has none or its thickness folds
/// to the constant 0 (the plain lobe), else the film with its thickness as connected.
fn thin_film(b: &Builder, inp: &NodeInputs) -> Option<ThinFilm> {
    use crate::types::ConstValue;
    inp.def.input("thinfilm_thickness")?;
    let t = inp.get("thinfilm_thickness");
    match crate::opt::fold::constant(b.program(), t) {
        Some(ConstValue::Float(0.0)) => None,
        _ => Some(ThinFilm {
            thickness: t,
            ior: inp.get("thinfilm_ior"),
        }),
    }
}

/// What the GGX lobes do not model yet, if the node asks for it: retroreflection, a
/// distribution other than GGX. Such a lobe is built without it and must specialize away
/// ([`unbuilt_lobe`]).
fn specular_options(b: &Builder, inp: &NodeInputs) -> Option<String> {
    if inp.def.input("retroreflective").is_some()
        && const_bool(b, inp, "retroreflective").unwrap_or(true)
    {
        return Some("retroreflective lobes are not built yet".into());
    }
    if inp.def.input("distribution").is_some() && inp.string("distribution") != "ggx" {
        return Some(format!(
            "microfacet distribution `{}` is not built (only ggx)",
            inp.string("distribution")
        ));
    }
    None
}

/// The `scatter_mode` input (`R` where the nodedef has none).
fn scatter_mode(inp: &NodeInputs) -> Result<ScatterMode, String> {
    if inp.def.input("scatter_mode").is_none() {
        return Ok(ScatterMode::R);
    }
    let s = inp.string("scatter_mode");
    ScatterMode::from_name(s).ok_or_else(|| format!("scatter_mode `{s}` is not one of R, T, RT"))
}

/// The component of a specular interface: `specular` for reflection, `transmission` for
/// lobes that transmit.
fn specular_component(mode: ScatterMode) -> &'static str {
    match mode {
        ScatterMode::R => "specular",
        ScatterMode::T | ScatterMode::RT => "transmission",
    }
}

fn dielectric(b: &mut Builder, inp: &NodeInputs) -> Out {
    let unbuilt = specular_options(b, inp);
    let thin_film = thin_film(b, inp);
    let mode = scatter_mode(inp)?;
    let kind = LobeKind::Dielectric {
        tint: inp.get("tint"),
        ior: inp.get("ior"),
        roughness: inp.get("roughness"),
        scatter_mode: mode,
        thin_film,
    };
    unbuilt_lobe(b, inp, kind, specular_component(mode), unbuilt)
}

fn conductor(b: &mut Builder, inp: &NodeInputs) -> Out {
    let unbuilt = specular_options(b, inp);
    let thin_film = thin_film(b, inp);
    let kind = LobeKind::Conductor {
        ior: inp.get("ior"),
        extinction: inp.get("extinction"),
        roughness: inp.get("roughness"),
        thin_film,
    };
    unbuilt_lobe(b, inp, kind, "specular", unbuilt)
}

fn generalized_schlick(b: &mut Builder, inp: &NodeInputs) -> Out {
    let unbuilt = specular_options(b, inp);
    let thin_film = thin_film(b, inp);
    let mode = scatter_mode(inp)?;
    let kind = LobeKind::GeneralizedSchlick {
        color0: inp.get("color0"),
        color82: inp.get("color82"),
        color90: inp.get("color90"),
        exponent: inp.get("exponent"),
        roughness: inp.get("roughness"),
        scatter_mode: mode,
        thin_film,
    };
    unbuilt_lobe(b, inp, kind, specular_component(mode), unbuilt)
}

/// `generalized_schlick_edf`: the base EDF's radiance times `mix(color0, color90, (1 −
/// cos θ)^exponent)`, `cos θ = clamp(|N·V|, ε, 1)` (the shading normal turned to the viewer).
fn schlick_edf(b: &mut Builder, inp: &NodeInputs) -> Out {
    let base = closure_in(inp, "base");
    let n = b.stream(Stream::N);
    let n = b.normalize(n);
    let wo = view_dir(b);
    let c = b.dot(n, wo);
    let c = b.unary(UnOp::Abs, c);
    let (eps, one) = (b.float(1e-8), b.float(1.0));
    let c = b.clamp(c, eps, one);
    let x = b.sub(one, c);
    let k = b.binary(crate::ir::BinOp::Pow, x, inp.get("exponent"));
    let f = b.mix(inp.get("color0"), inp.get("color90"), k);
    let c = base.scaled(b, f);
    one_closure(b, c)
}

/// `absorption_vdf`, `anisotropic_vdf`: the medium inside a surface. Volumes are not
/// built; a medium that neither absorbs nor scatters (its coefficients the compile-time 0,
/// as the bxdf graphs give it with `transmission_depth` 0) is a vacuum: no lobes, so
/// `layer(top, vacuum)` is the top.
fn medium(b: &mut Builder, inp: &NodeInputs) -> Out {
    use crate::types::ConstValue;
    for port in ["absorption", "scattering"] {
        if inp.def.input(port).is_none() {
            continue;
        }
        match crate::opt::fold::constant(b.program(), inp.get(port)) {
            Some(ConstValue::Vec3(v)) if v.iter().all(|x| *x == 0.0) => {}
            Some(c) => {
                return Err(format!(
                    "volumes are not built yet: a medium needs `{port}` = 0 (a vacuum), it is {c}"
                ));
            }
            None => {
                return Err(format!(
                    "volumes are not built yet: a medium needs `{port}` = 0 (a vacuum), it is not a compile-time constant"
                ));
            }
        }
    }
    one_closure(b, Closure::default())
}

fn one_closure(b: &mut Builder, c: Closure) -> Out {
    one(LowVal::closure(b, c))
}

fn uniform_edf(b: &mut Builder, inp: &NodeInputs) -> Out {
    let c = inp.get("color");
    one(LowVal::closure(b, Closure::emitter(c)))
}

/// The lobe list at closure input `port` (empty where the nodedef has no such input).
fn closure_in(inp: &NodeInputs, port: &str) -> Closure {
    inp.def
        .input(port)
        .map(|_| inp.low(port).as_closure())
        .unwrap_or_default()
}

/// `surface(bsdf, edf, opacity)`: the BSDF's lobes, the EDF's emission and the cutout
/// opacity (`thin_walled` is not read: every surface is two-sided with the normal turned
/// to the viewer).
fn surface(b: &mut Builder, inp: &NodeInputs) -> Out {
    let bsdf = closure_in(inp, "bsdf");
    let edf = closure_in(inp, "edf");
    let mut c = Closure::add(b, &bsdf, &edf);
    c.opacity = Some(inp.get("opacity"));
    one(LowVal::closure(b, c))
}

/// `surface_unlit`: emission `emission · emission_color`, straight-through transmission
/// `transmission · transmission_color` and the cutout `opacity` (MaterialX's
/// `mx_surface_unlit`). The transmission is a smooth dielectric of IOR 1 that only transmits:
/// no Fresnel reflection and no bending, so what lies behind shows through, tinted; at the
/// default `transmission = 0` its weight folds to zero and the lobe is gone.
fn surface_unlit(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (e, ec) = (inp.get("emission"), inp.get("emission_color"));
    let e = b.splat(Type::Color, e);
    let emission = b.mul(e, ec);
    let emit = Closure::emitter(emission);
    let (t, tc) = (inp.get("transmission"), inp.get("transmission_color"));
    let t = b.splat(Type::Color, t);
    let weight = b.mul(t, tc);
    let kind = LobeKind::Dielectric {
        tint: b.color([1.0; 3]),
        ior: b.float(1.0),
        roughness: b.zero(Type::Vec2),
        scatter_mode: ScatterMode::T,
        thin_film: None,
    };
    let n = b.stream(Stream::N);
    let t0 = b.zero(Type::Vec3);
    let frame = frame_at(b, n, t0);
    let transmit = Closure::lobe(Lobe {
        kind,
        weight,
        frame,
        component: specular_component(ScatterMode::T),
        unbuilt: None,
    });
    let mut c = Closure::add(b, &emit, &transmit);
    c.opacity = Some(inp.get("opacity"));
    one(LowVal::closure(b, c))
}

/// `surfacematerial`: its `surfaceshader` (the back-face shader and displacement are not
/// built; the front shader shades both sides).
fn surfacematerial(b: &mut Builder, inp: &NodeInputs) -> Out {
    let c = closure_in(inp, "surfaceshader");
    one(LowVal::closure(b, c))
}

fn mix(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (fg, bg) = (closure_in(inp, "fg"), closure_in(inp, "bg"));
    let t = inp.get("mix");
    let c = Closure::mix(b, &bg, &fg, t);
    one(LowVal::closure(b, c))
}

fn add(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (x, y) = (closure_in(inp, "in1"), closure_in(inp, "in2"));
    let c = Closure::add(b, &x, &y);
    one(LowVal::closure(b, c))
}

fn multiply(b: &mut Builder, inp: &NodeInputs) -> Out {
    let x = closure_in(inp, "in1");
    let k = inp.get("in2");
    let c = x.scaled(b, k);
    one(LowVal::closure(b, c))
}

/// `dot` of a closure: its input, unchanged.
fn dot(b: &mut Builder, inp: &NodeInputs) -> Out {
    let c = closure_in(inp, "in");
    one(LowVal::closure(b, c))
}

fn layer(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (top, base) = (closure_in(inp, "top"), closure_in(inp, "base"));
    let wo = view_dir(b);
    let c = Closure::layer(b, &top, &base, wo);
    one(LowVal::closure(b, c))
}
