//! The closure atoms of MaterialX's pbrlib: BSDF and EDF nodes become lobe lists
//! ([`crate::closure`]), `mix`/`add`/`multiply`/`layer` of closures act on the lists,
//! `surface` and `surfacematerial` carry them to the material output, where the surface
//! lowering ([`crate::closure::shade`]) turns them into light.
//!
//! This module owns which pbrlib node makes which lobe and how its inputs map onto the
//! lobe's parameters; it must not hold lobe formulas (the lobe files do) nor the light loop.

use crate::closure::{Closure, Frame, Lobe, LobeKind};
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
    ("uniform_edf", uniform_edf),
    ("surface", surface),
    ("surfacematerial", surfacematerial),
    ("mix", mix),
    ("add", add),
    ("multiply", multiply),
    ("layer", layer),
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
        "volume" | "volumematerial" | "absorption_vdf" | "anisotropic_vdf" => {
            "no volumes yet (VDF closures)"
        }
        "displacement" => "no displacement yet",
        "light" => "light shaders are not built: lights come from the scene",
        "chiang_hair_bsdf" => "no hair BSDF yet",
        "conical_edf" | "measured_edf" | "generalized_schlick_edf" => {
            "only uniform_edf emission is built"
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
    let wo = view_dir(b);
    Frame::new(b, n, t, wo)
}

/// A one-lobe closure weighted by the node's `weight` input.
fn lobe(b: &mut Builder, inp: &NodeInputs, kind: LobeKind, component: &'static str) -> Out {
    let w = inp.get("weight");
    let weight = b.splat(Type::Color, w);
    let frame = frame(b, inp);
    let c = Closure::lobe(Lobe {
        kind,
        weight,
        frame,
        component,
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
    if inp.def.input("mode").is_some() && inp.string("mode") != "conty_kulla" {
        return Err(format!(
            "sheen mode `{}` is not built yet (only conty_kulla)",
            inp.string("mode")
        ));
    }
    let kind = LobeKind::Sheen {
        color: inp.get("color"),
        roughness: inp.get("roughness"),
    };
    lobe(b, inp, kind, "sheen")
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

fn layer(b: &mut Builder, inp: &NodeInputs) -> Out {
    let (top, base) = (closure_in(inp, "top"), closure_in(inp, "base"));
    let wo = view_dir(b);
    let c = Closure::layer(b, &top, &base, wo);
    one(LowVal::closure(b, c))
}
