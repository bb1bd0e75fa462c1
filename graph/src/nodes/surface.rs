//! Standard nodes: surface shaders (`lambert`, `phong`, `blinn`, `surfaceShader`) and
//! lights (`pointLight`, `spotLight`, `directionalLight`, `ambientLight`).
//!
//! # Units (DESIGN §3)
//!
//! Colors are linear RGB radiance. A surface's `outColor` is the radiance it sends towards
//! the viewer: the sum over light samples of `BRDF · Cl · max(0, N·L) · vis`, where `Cl` is
//! what the light sample delivers at the point (an irradiance perpendicular to `L`: intensity
//! / r² for point and spot lights, `E` for distant lights) and `vis` its visibility
//! (`light.visible`: 0 where the renderer's scene blocks it, else 1, always 1 without a
//! scene), plus ambient and emitted terms. The BRDFs are normalized: Lambert is
//! `albedo / π`, Phong `(n+2)/(2π)·cosⁿ`, Blinn the exact normal-incidence normalization of
//! the Blinn–Phong lobe, so with `specularColor ≤ 1` no lobe reflects more than it receives.
//!
//! # Render components (DESIGN §8)
//!
//! `outColor` carries one part per component: [`DIFFUSE`], [`SPECULAR`] (not for
//! `lambert`), [`REFLECTION`] and [`REFRACTION`] (rays traced by the renderer's scene),
//! [`INDIRECT`] (ambient light) and [`EMISSION`]. Each part is computed inside
//! `component_enabled(k)`, and each light loop and each traced ray sits inside its
//! component's part, so a material specialized without a component does none of its work.
//! `outShadow` carries the [`SHADOW`] part: the diffuse light that shadows take away. It is
//! not part of `outColor` (the total of `outColor`, the beauty, is shadowed already;
//! `diffuse + shadow` is the unshadowed diffuse light).
//!
//! # Secondary rays
//!
//! Reflections and refractions are traced by the renderer ([`crate::ir::Op::Trace`]);
//! without a scene they are black. Shadows come from the light loop: every light sample is
//! shaded, and `light.visible` (0 for a sample the scene finds blocked, else 1) multiplies
//! the diffuse and specular terms. Without a scene every sample is visible and the results
//! are those of a renderer without shadows, bit for bit.
//!
//! # Hard inputs
//!
//! Every cosine is `max(x, 0)` with `x` first, so a NaN cosine (from a NaN normal or a NaN
//! `I`) becomes 0, as do back-facing and grazing lights; normals and view vectors go through
//! the total `normalize`, so a zero normal or a zero `I` gives a zero vector and no NaN.
//! What non-finite value still escapes is caught by the material output guard.

use super::{
    LightDesc, LightKind, LowVal, NodeDef, NodeInputs, NodeKind, NodeLibrary, lowering, port,
};
use crate::ir::{BinOp, Builder, RAY_REFLECTION, RAY_REFRACTION, Stream, UnOp, Value};
use crate::types::{ConstValue, Type};
use std::f64::consts::PI;

/// Render component of light reflected diffusely from the light loop.
pub const DIFFUSE: &str = "diffuse";
/// Render component of light reflected specularly (the highlight) from the light loop.
pub const SPECULAR: &str = "specular";
/// Render component of ambient light (ambient lights and a surface's `ambientColor`): light
/// without direction, the stand-in for indirect illumination (thesis §4.3.2).
pub const INDIRECT: &str = "indirect";
/// Render component of light the surface emits itself (`incandescence`, `surfaceShader`).
pub const EMISSION: &str = "emission";
/// Render component of light arriving along the mirror direction (traced reflection rays).
pub const REFLECTION: &str = "reflection";
/// Render component of light arriving through the surface (traced refraction rays).
pub const REFRACTION: &str = "refraction";
/// Render component of the diffuse light blocked by shadows (the `outShadow` output).
pub const SHADOW: &str = "shadow";

/// Smallest eccentricity `blinn` uses (`n = 2/0.01² − 2 = 19998`): keeps the exponent finite.
pub const MIN_ECCENTRICITY: f64 = 0.01;

/// Registers the surface and light nodes.
pub fn register(lib: &mut NodeLibrary) {
    lib.add(lambert_def());
    lib.add(phong_def());
    lib.add(blinn_def());
    lib.add(surface_shader_def());
    lib.add(point_light_def());
    lib.add(spot_light_def());
    lib.add(directional_light_def());
    lib.add(ambient_light_def());
}

// ---- surfaces ----

/// The part of the surface nodes' docs they share.
macro_rules! surface_common_doc {
    () => {
        "Common inputs (Maya names): `albedo = color · diffuse`; `N = normalize(normal)` \
(world space); `V = −normalize(I)`; `P` the shaded point. For each non-ambient light sample, \
`L` is the unit direction to the light and `Cl` the irradiance it delivers perpendicular to \
`L` (`intensity/r²` for point and spot lights, the irradiance `E` for directional ones).

`outColor` is the sum of these parts, each computed only when its render component is \
active (`phong` and `blinn` add the `specular` part described in their entries, and a \
mirror term to `reflection`):

- `diffuse`: `Σ_samples (albedo/π) · Cl · max(0, N·L) · vis` (Lambert BRDF `albedo/π`), \
  where `vis` is 0 for a light sample the renderer's scene finds blocked, else 1 (always 1 \
  without a scene).
- `reflection`: `w_r · trace(R)`, a reflection ray (`RAY_REFLECTION`) along the mirror \
  direction `R = I + 2 cosθ_i N_v` (`N_v` the normal turned to face `I`, `cosθ_i = \
  −I·N_v`), with `w_r = mirror + (refractions ? transparency · F : 0)`: `mirror = \
  reflectivity · reflectedColor` for `phong` and `blinn` (0 for `lambert`), a mirror \
  reflectance used as given (Fresnel factor 1, Maya's `reflectivity`), and `transparency · \
  F` the light the transparent part's dielectric interface reflects (`F` below). No ray is \
  traced where `w_r = 0`.
- `refraction` (when `refractions` is on and `transparency ≠ 0`): `transparency · (1 − F) \
  · trace(T)`, a refraction ray (`RAY_REFRACTION`) along `T = η_r I + (η_r cosθ_i − \
  cosθ_t) N_v`; 0 under total internal reflection, where `F = 1` sends all the light to \
  `reflection`.
- `indirect`: `albedo · La + color · ambientColor`, where `La` is the sum of the ambient \
  lights (a uniform radiance `La` reflected by a Lambertian surface gives `albedo · La`); \
  `ambientColor` is the material's own ambient radiance, scaled by `color` but not by \
  `diffuse`, as in Maya.
- `emission`: `incandescence`.

The dielectric (when `refractions` is on): `I` is the unit incident direction. The ray \
leaves the material where `I·Ng > 0` (`Ng`, the geometric normal, points out of the \
material whichever side the viewer is on; a zero `Ng` counts as entering), so the relative \
index is `η_r = refractiveIndex` leaving and `1/refractiveIndex` entering (outside is \
vacuum, index 1). `cos²θ_t = 1 − η_r² (1 − cos²θ_i)`; where it is negative the light is \
totally internally reflected: `F = 1` and no refraction ray is traced. Elsewhere `F` is \
the exact Fresnel reflectance of unpolarized light, `F = (r_s² + r_p²)/2` with `r_s = \
(η_r cosθ_i − cosθ_t)/(η_r cosθ_i + cosθ_t)` and `r_p = (cosθ_i − η_r cosθ_t)/(cosθ_i + \
η_r cosθ_t)` (divisions total: `0/0 = 0`), clamped to [0, 1]. At normal incidence with \
`refractiveIndex = 1`, `F = 0` and `T = I`: the surface passes `transparency · trace(I)`; \
at grazing incidence `F → 1`. A glass that conserves energy has `reflectivity = 0`, \
`transparency = 1` (and no diffuse): it sends `F · trace(R) + (1 − F) · trace(T)`. \
Traced directions are normalized; a zero or NaN direction traces nothing (black).

`outShadow`, component `shadow`: `Σ_samples (albedo/π) · Cl · max(0, N·L) · (1 − vis)`, \
the diffuse light the shadows take away, so `diffuse + shadow` is the unshadowed diffuse \
light; 0 without a scene. It is a separate output, not part of `outColor`. Specular light \
is shadowed the same way but has no shadow part.

`outTransparency = transparency` when `refractions` is off: reported for the renderer to \
composite with; it does not change `outColor` (Maya, too, applies `1 − transparency` only \
when compositing). With `refractions` on the light through the surface is traced (part \
`refraction`), so `outTransparency = 0`: nothing is left to composite. \
`outGlow = incandescence · glowIntensity`, without component parts.

Hard inputs: every cosine is `max(x, 0)`, so lights behind or grazing the surface \
(`N·L ≤ 0`) add 0; a zero normal gives `N = 0` and so 0 from every light; a NaN normal \
makes every cosine 0 (`max(NaN, 0) = 0`); a zero `I` gives `V = 0`; a point light at `P` \
delivers `Cl = 0`. `N` is assumed to face the viewer (the `N` stream does). Negative \
colors and coefficients are used as given."
    };
}

fn common_inputs() -> Vec<super::PortDef> {
    vec![
        port::color(
            "color",
            [0.5, 0.5, 0.5],
            "Surface color; the diffuse albedo is `color · diffuse`.",
        ),
        port::float(
            "diffuse",
            0.8,
            "Diffuse coefficient: scales `color` into the albedo.",
        ),
        port::color(
            "transparency",
            [0.0, 0.0, 0.0],
            "Transparency: passed to `outTransparency` (it does not change `outColor`), or, \
             with `refractions` on, the weight of the traced refraction and reflection.",
        ),
        port::color(
            "ambientColor",
            [0.0, 0.0, 0.0],
            "Material ambient radiance; adds `color · ambientColor` (component `indirect`).",
        ),
        port::color(
            "incandescence",
            [0.0, 0.0, 0.0],
            "Emitted radiance (component `emission`).",
        ),
        port::stream(
            "normal",
            Type::Vec3,
            Stream::N,
            "Shading normal, world space; normalized before use (a zero normal reflects nothing).",
        ),
        port::float(
            "glowIntensity",
            0.0,
            "Glow: `outGlow = incandescence · glowIntensity`.",
        ),
        port::boolean(
            "refractions",
            false,
            "Trace the light through the transparent part (component `refraction`) as a \
             dielectric of index `refractiveIndex`; `outTransparency` is then 0.",
        ),
        port::float(
            "refractiveIndex",
            1.5,
            "Index of refraction inside the surface (outside: 1); used where `refractions` is on.",
        ),
    ]
}

/// The mirror-reflection inputs of `phong` and `blinn`.
fn mirror_inputs() -> Vec<super::PortDef> {
    vec![
        port::float(
            "reflectivity",
            0.0,
            "Mirror reflectance, the weight of the traced reflection (component \
             `reflection`). Maya's default is 0.5; ours is 0 so that a material without it \
             traces nothing.",
        ),
        port::color(
            "reflectedColor",
            [1.0, 1.0, 1.0],
            "Tint of the mirror reflection: `reflectivity · reflectedColor`.",
        ),
    ]
}

fn surface_outputs(with_specular: bool) -> Vec<super::OutDef> {
    vec![
        port::out(
            "outColor",
            Type::Color,
            if with_specular {
                "Radiance towards the viewer; parts `diffuse`, `specular`, `reflection`, \
                 `refraction`, `indirect`, `emission`."
            } else {
                "Radiance towards the viewer; parts `diffuse`, `reflection`, `refraction`, \
                 `indirect`, `emission`."
            },
        ),
        port::out(
            "outTransparency",
            Type::Color,
            "The `transparency` input, for compositing (0 when `refractions` is on).",
        ),
        port::out(
            "outGlow",
            Type::Color,
            "`incandescence · glowIntensity` (no component parts).",
        ),
        port::out(
            "outShadow",
            Type::Color,
            "Diffuse light blocked by shadows; part `shadow` (not in `outColor`).",
        ),
    ]
}

fn lambert_def() -> NodeDef {
    NodeDef {
        name: "lambert",
        category: "surface",
        doc: concat!(
            "A perfectly diffuse (Lambertian) surface: BRDF `albedo/π`. `outColor` has the \
             parts `diffuse`, `reflection`, `refraction`, `indirect` and `emission` (no \
             `specular`; `reflection` only from a refractive surface's interface).\n\n",
            surface_common_doc!()
        ),
        generic: &[],
        inputs: common_inputs(),
        outputs: surface_outputs(false),
        lower: lower_lambert,
        kind: NodeKind::Shading,
    }
}

fn lower_lambert(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    lower_surface(b, inp, Lobe::None)
}

fn phong_def() -> NodeDef {
    let mut inputs = common_inputs();
    inputs.push(port::float(
        "cosinePower",
        20.0,
        "Phong exponent `n`; values below 0 (and NaN) are taken as 0.",
    ));
    inputs.push(port::color(
        "specularColor",
        [0.5, 0.5, 0.5],
        "Specular reflectance `ks` (directional albedo of the lobe at normal incidence).",
    ));
    inputs.extend(mirror_inputs());
    NodeDef {
        name: "phong",
        category: "surface",
        doc: concat!(
            "Lambert diffuse plus an energy-normalized Phong highlight (the modified Phong \
             of Lafortune and Willems).\n\n\
             `specular`: `Σ_lights ks · (n+2)/(2π) · max(0, R·V)ⁿ · Cl · max(0, N·L)`, \
             with `ks = specularColor`, `n = max(cosinePower, 0)` and `R = reflect(−L, N) = \
             2(N·L)N − L`. The factor `(n+2)/(2π)` makes the lobe's directional albedo \
             exactly `ks` at normal incidence and less elsewhere, so `ks ≤ 1` conserves \
             energy; `n = 0` is a Lambertian lobe of albedo `ks`. The highlight of a blocked \
             light sample is 0 (it is multiplied by `vis`, below). A NaN `R·V` counts as 0; \
             a zero `I` gives `R·V = 0`, so no highlight (unless `n = 0`).\n\n",
            surface_common_doc!()
        ),
        generic: &[],
        inputs,
        outputs: surface_outputs(true),
        lower: lower_phong,
        kind: NodeKind::Shading,
    }
}

fn lower_phong(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    lower_surface(b, inp, Lobe::Phong)
}

fn blinn_def() -> NodeDef {
    let mut inputs = common_inputs();
    inputs.push(port::float(
        "eccentricity",
        0.3,
        "Highlight size `e`, clamped to [0.01, 1]; exponent `n = 2/e² − 2`.",
    ));
    inputs.push(port::float(
        "specularRollOff",
        0.7,
        "Schlick reflectance at normal incidence relative to grazing, clamped to [0, 1].",
    ));
    inputs.push(port::color(
        "specularColor",
        [0.5, 0.5, 0.5],
        "Specular reflectance `ks`; the lobe's albedo at normal incidence is about `ks · r`.",
    ));
    inputs.extend(mirror_inputs());
    NodeDef {
        name: "blinn",
        category: "surface",
        doc: concat!(
            "Lambert diffuse plus an energy-normalized Blinn–Phong highlight with a \
             Fresnel-like roll-off.\n\n\
             `specular`: `Σ_lights ks · F · k(n) · max(0, N·H)ⁿ · Cl · max(0, N·L)`, with \
             `ks = specularColor`, `H = normalize(L + V)`, and:\n\n\
             - `n = 2/e² − 2`, `e = clamp(eccentricity, 0.01, 1)`: the usual map from a \
             Beckmann roughness to a Blinn exponent; `e = 1` gives `n = 0`, a uniform lobe; \
             the lower clamp keeps `n ≤ 19998` and the division finite (a NaN \
             eccentricity counts as 0.01).\n\
             - `k(n) = (n+2)(n+4) / (8π (2^(−n/2) + n))`: the exact normalization that \
             makes the lobe's directional albedo 1 at normal incidence (less elsewhere); \
             `k(0) = 1/π`. The common approximation `(n+8)/(8π)` overshoots it by up to \
             7% (near `n = 11`) and is not used.\n\
             - `F = r + (1 − r)(1 − max(0, V·H))⁵`, `r = clamp(specularRollOff, 0, 1)` (NaN \
             counts as 0): Schlick's Fresnel curve with `r` the reflectance at normal \
             incidence relative to grazing, where it rises to 1. This approximates Maya's \
             roll-off (weaker highlight face-on, full at grazing); `r = 1` turns it off. \
             Since `F ≤ 1`, `ks ≤ 1` still conserves energy. The highlight of a blocked \
             light sample is 0 (it is multiplied by `vis`, below).\n\n\
             A zero `I` gives `V = 0`, so `H = L` and `F = 1`.\n\n",
            surface_common_doc!()
        ),
        generic: &[],
        inputs,
        outputs: surface_outputs(true),
        lower: lower_blinn,
        kind: NodeKind::Shading,
    }
}

fn lower_blinn(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    lower_surface(b, inp, Lobe::Blinn)
}

/// The specular lobe of a surface.
#[derive(Clone, Copy, PartialEq)]
enum Lobe {
    None,
    Phong,
    Blinn,
}

/// `v · s` for a color or vector `v` and a float `s`.
fn scale(b: &mut Builder, v: Value, s: Value) -> Value {
    let ty = b.ty(v);
    let s = b.splat(ty, s);
    b.mul(v, s)
}

/// `max(x, 0)`, with `x` first so that a NaN `x` gives 0.
fn pos(b: &mut Builder, x: Value) -> Value {
    let zero = b.float(0.0);
    b.max(x, zero)
}

fn lower_surface(b: &mut Builder, inp: &NodeInputs, lobe: Lobe) -> Result<Vec<LowVal>, String> {
    let color = inp.get("color");
    let kd = inp.get("diffuse");
    let albedo = scale(b, color, kd);
    let p = b.stream(Stream::P);
    let normal = inp.get("normal");
    let n = b.normalize(normal);

    let mut parts = Vec::new();
    parts.push(lowering::contribution(b, DIFFUSE, Type::Color, |b| {
        diffuse_light(b, p, n, albedo, false)
    }));

    match lobe {
        Lobe::None => {}
        Lobe::Phong => {
            let ks = inp.get("specularColor");
            let cp = inp.get("cosinePower");
            parts.push(lowering::contribution(b, SPECULAR, Type::Color, |b| {
                let e = pos(b, cp);
                let v = view_vector(b);
                let sum = b.illuminance(p, |b, l, cl| {
                    let d = b.dot(n, l);
                    let ndl = pos(b, d);
                    // R = 2(N·L)N − L
                    let two = b.float(2.0);
                    let two_d = b.mul(two, d);
                    let two_dn = scale(b, n, two_d);
                    let r = b.sub(two_dn, l);
                    let rv = b.dot(r, v);
                    let rv = pos(b, rv);
                    let lobe = b.binary(BinOp::Pow, rv, e);
                    let w = b.mul(lobe, ndl);
                    let vis = b.light_visible();
                    let w = b.mul(w, vis);
                    vec![scale(b, cl, w)]
                });
                // (n + 2) / (2π)
                let two = b.float(2.0);
                let e2 = b.add(e, two);
                let inv = b.float(1.0 / (2.0 * PI));
                let norm = b.mul(e2, inv);
                let kn = scale(b, ks, norm);
                b.mul(kn, sum[0])
            }));
        }
        Lobe::Blinn => {
            let ks = inp.get("specularColor");
            let ecc = inp.get("eccentricity");
            let rolloff = inp.get("specularRollOff");
            parts.push(lowering::contribution(b, SPECULAR, Type::Color, |b| {
                let (lo, hi) = (b.float(MIN_ECCENTRICITY), b.float(1.0));
                let ecc = b.clamp(ecc, lo, hi);
                // n = 2/e² − 2
                let e2 = b.mul(ecc, ecc);
                let two = b.float(2.0);
                let q = b.div(two, e2);
                let e = b.sub(q, two);
                let (zero, one) = (b.float(0.0), b.float(1.0));
                let r = b.clamp(rolloff, zero, one);
                let one_r = b.sub(one, r);
                let v = view_vector(b);
                let sum = b.illuminance(p, |b, l, cl| {
                    let d = b.dot(n, l);
                    let ndl = pos(b, d);
                    let lv = b.add(l, v);
                    let h = b.normalize(lv);
                    let nh = b.dot(n, h);
                    let nh = pos(b, nh);
                    let vh = b.dot(v, h);
                    let vh = pos(b, vh);
                    // F = r + (1 − r)(1 − V·H)⁵
                    let one = b.float(1.0);
                    let c = b.sub(one, vh);
                    let c2 = b.mul(c, c);
                    let c4 = b.mul(c2, c2);
                    let c5 = b.mul(c4, c);
                    let fr = b.mul(one_r, c5);
                    let fresnel = b.add(r, fr);
                    let lobe = b.binary(BinOp::Pow, nh, e);
                    let w = b.mul(lobe, ndl);
                    let w = b.mul(fresnel, w);
                    let vis = b.light_visible();
                    let w = b.mul(w, vis);
                    vec![scale(b, cl, w)]
                });
                let norm = crate::closure::blinn::normalization(b, e);
                let kn = scale(b, ks, norm);
                b.mul(kn, sum[0])
            }));
        }
    }

    let traced = Traced {
        n,
        transparency: inp.get("transparency"),
        refractions: inp.get("refractions"),
        ior: inp.get("refractiveIndex"),
        mirror: match lobe {
            Lobe::None => None,
            Lobe::Phong | Lobe::Blinn => Some((inp.get("reflectivity"), inp.get("reflectedColor"))),
        },
    };
    parts.push(lowering::contribution(b, REFLECTION, Type::Color, |b| {
        reflection(b, &traced)
    }));
    parts.push(lowering::contribution(b, REFRACTION, Type::Color, |b| {
        refraction(b, &traced)
    }));

    let ambient_color = inp.get("ambientColor");
    parts.push(lowering::contribution(b, INDIRECT, Type::Color, |b| {
        let la = b.ambient();
        let reflected = b.mul(albedo, la);
        let own = b.mul(color, ambient_color);
        b.add(reflected, own)
    }));

    let incandescence = inp.get("incandescence");
    parts.push(lowering::contribution(b, EMISSION, Type::Color, |_| {
        incandescence
    }));

    let out = lowering::sum_parts(b, Type::Color, parts);
    let transparency = inp.get("transparency");
    let zero = b.zero(Type::Color);
    let transparency = b.select(traced.refractions, zero, transparency);
    let glow_intensity = inp.get("glowIntensity");
    let glow = scale(b, incandescence, glow_intensity);
    let shadow = lowering::contribution(b, SHADOW, Type::Color, |b| {
        diffuse_light(b, p, n, albedo, true)
    });
    let shadow = lowering::sum_parts(b, Type::Color, vec![shadow]);
    Ok(vec![
        out,
        LowVal::plain(transparency),
        LowVal::plain(glow),
        shadow,
    ])
}

/// `(albedo/π) · Σ_samples Cl · max(0, N·L) · vis`, or with `1 − vis` (the light shadows
/// take away) when `blocked`.
fn diffuse_light(b: &mut Builder, p: Value, n: Value, albedo: Value, blocked: bool) -> Value {
    let sum = b.illuminance(p, |b, l, cl| {
        let d = b.dot(n, l);
        let ndl = pos(b, d);
        let vis = b.light_visible();
        let vis = if blocked {
            let one = b.float(1.0);
            b.sub(one, vis)
        } else {
            vis
        };
        let w = b.mul(ndl, vis);
        vec![scale(b, cl, w)]
    });
    let k = b.float(1.0 / PI);
    let brdf = scale(b, albedo, k);
    b.mul(brdf, sum[0])
}

/// What the traced parts of a surface read.
struct Traced {
    /// The unit shading normal.
    n: Value,
    /// `transparency` (color).
    transparency: Value,
    /// `refractions` (bool).
    refractions: Value,
    /// `refractiveIndex` (float).
    ior: Value,
    /// `reflectivity` and `reflectedColor` (`phong`, `blinn`).
    mirror: Option<(Value, Value)>,
}

/// The incident direction and the normal facing it.
struct Facing {
    /// `I`, normalized (eye → P).
    i: Value,
    /// The normal turned to face `I`: `−N` where `I·N > 0`, else `N`.
    nv: Value,
    /// `clamp(−I·N_v, 0, 1)` (NaN → 0).
    cos_i: Value,
}

fn facing(b: &mut Builder, n: Value) -> Facing {
    let i = b.stream(Stream::I);
    let i = b.normalize(i);
    let idn = b.dot(i, n);
    let zero = b.float(0.0);
    let back = b.binary(BinOp::Gt, idn, zero);
    let neg_n = b.unary(UnOp::Neg, n);
    let nv = b.select(back, neg_n, n);
    let d = b.dot(i, nv);
    let c = b.unary(UnOp::Neg, d);
    let (zero, one) = (b.float(0.0), b.float(1.0));
    let cos_i = b.clamp(c, zero, one);
    Facing { i, nv, cos_i }
}

/// The dielectric interface at the point (see the surfaces' docs): the relative index, the
/// cosine of the refracted angle, whether the light is totally internally reflected, and
/// the Fresnel reflectance `F` (1 under total internal reflection).
struct Interface {
    eta: Value,
    cos_t: Value,
    tir: Value,
    f: Value,
}

fn interface(b: &mut Builder, fc: &Facing, ior: Value) -> Interface {
    let ng = b.stream(Stream::Ng);
    let ing = b.dot(fc.i, ng);
    let zero = b.float(0.0);
    let leaving = b.binary(BinOp::Gt, ing, zero);
    let one = b.float(1.0);
    let inv = b.div(one, ior);
    let eta = b.select(leaving, ior, inv);
    // cos²θ_t = 1 − η²(1 − cos²θ_i)
    let c2 = b.mul(fc.cos_i, fc.cos_i);
    let sin2_i = b.sub(one, c2);
    let eta2 = b.mul(eta, eta);
    let sin2_t = b.mul(eta2, sin2_i);
    let k = b.sub(one, sin2_t);
    let tir = b.binary(BinOp::Lt, k, zero);
    let k = pos(b, k);
    let cos_t = b.unary(UnOp::Sqrt, k);
    // Exact Fresnel for unpolarized light.
    let ec = b.mul(eta, fc.cos_i);
    let et = b.mul(eta, cos_t);
    let rs_n = b.sub(ec, cos_t);
    let rs_d = b.add(ec, cos_t);
    let rs = b.div(rs_n, rs_d);
    let rp_n = b.sub(fc.cos_i, et);
    let rp_d = b.add(fc.cos_i, et);
    let rp = b.div(rp_n, rp_d);
    let rs2 = b.mul(rs, rs);
    let rp2 = b.mul(rp, rp);
    let sum = b.add(rs2, rp2);
    let half = b.float(0.5);
    let f = b.mul(sum, half);
    let f = b.clamp(f, zero, one);
    let f = b.select(tir, one, f);
    Interface { eta, cos_t, tir, f }
}

/// Whether any component of a float or color is nonzero (a NaN is nonzero).
fn nonzero(b: &mut Builder, v: Value) -> Value {
    let zero = b.float(0.0);
    let ty = b.ty(v);
    if ty == Type::Float {
        return b.binary(BinOp::Ne, v, zero);
    }
    let mut any = None;
    for k in 0..ty.width() {
        let x = b.extract(v, k);
        let ne = b.binary(BinOp::Ne, x, zero);
        any = Some(match any {
            None => ne,
            Some(a) => b.binary(BinOp::Or, a, ne),
        });
    }
    any.unwrap_or(zero)
}

/// Whether the transparent part is a refracting dielectric: `refractions && transparency ≠ 0`.
fn refracting(b: &mut Builder, t: &Traced) -> Value {
    let some = nonzero(b, t.transparency);
    b.binary(BinOp::And, t.refractions, some)
}

/// The `reflection` part: `w_r · trace(R, RAY_REFLECTION)`, traced only where `w_r ≠ 0`.
fn reflection(b: &mut Builder, t: &Traced) -> Value {
    let mirror = match t.mirror {
        Some((reflectivity, tint)) => scale(b, tint, reflectivity),
        None => b.zero(Type::Color),
    };
    let fc = facing(b, t.n);
    let on = refracting(b, t);
    let w = b.if_(
        on,
        |b| {
            let it = interface(b, &fc, t.ior);
            let tf = scale(b, t.transparency, it.f);
            vec![b.add(mirror, tf)]
        },
        |_| vec![mirror],
    )[0];
    // R = I + 2 cosθ_i N_v
    let two = b.float(2.0);
    let c2 = b.mul(two, fc.cos_i);
    let off = scale(b, fc.nv, c2);
    let r = b.add(fc.i, off);
    let r = b.normalize(r);
    let any = nonzero(b, w);
    b.if_(
        any,
        |b| {
            let l = b.trace(r, RAY_REFLECTION);
            vec![b.mul(w, l)]
        },
        |b| vec![b.zero(Type::Color)],
    )[0]
}

/// The `refraction` part: `transparency · (1 − F) · trace(T, RAY_REFRACTION)`, 0 under total
/// internal reflection and where the surface does not refract.
fn refraction(b: &mut Builder, t: &Traced) -> Value {
    let on = refracting(b, t);
    b.if_(
        on,
        |b| {
            let fc = facing(b, t.n);
            let it = interface(b, &fc, t.ior);
            b.if_(
                it.tir,
                |b| vec![b.zero(Type::Color)],
                |b| {
                    // T = η I + (η cosθ_i − cosθ_t) N_v
                    let ei = scale(b, fc.i, it.eta);
                    let ec = b.mul(it.eta, fc.cos_i);
                    let k = b.sub(ec, it.cos_t);
                    let kn = scale(b, fc.nv, k);
                    let dir = b.add(ei, kn);
                    let dir = b.normalize(dir);
                    let l = b.trace(dir, RAY_REFRACTION);
                    let one = b.float(1.0);
                    let tr = b.sub(one, it.f);
                    let w = scale(b, t.transparency, tr);
                    vec![b.mul(w, l)]
                },
            )
        },
        |b| vec![b.zero(Type::Color)],
    )[0]
}

/// `V = −normalize(I)`: unit direction from the point towards the viewer (zero for a zero
/// `I`).
fn view_vector(b: &mut Builder) -> Value {
    let i = b.stream(Stream::I);
    let i = b.normalize(i);
    b.unary(UnOp::Neg, i)
}

fn surface_shader_def() -> NodeDef {
    NodeDef {
        name: "surfaceShader",
        category: "surface",
        doc: "A flat surface (Maya's surfaceShader): outputs its inputs unchanged, ignoring \
              lights.\n\n\
              `outColor = outColor` (input). A connected value that carries render-component \
              parts (e.g. another surface's `outColor`) keeps them; a value without parts (a \
              constant, a texture) is tagged as component `emission` — a flat color is light \
              the surface sends out by itself — and so is 0 when `emission` is inactive. \
              `outTransparency` and `outGlow` pass through untagged.",
        generic: &[],
        inputs: vec![
            port::color(
                "outColor",
                [0.0, 0.0, 0.0],
                "Radiance to output; tagged `emission` unless it already has component parts.",
            ),
            port::color(
                "outTransparency",
                [0.0, 0.0, 0.0],
                "Transparency, passed through.",
            ),
            port::color("outGlow", [0.0, 0.0, 0.0], "Glow, passed through."),
        ],
        outputs: vec![
            port::out(
                "outColor",
                Type::Color,
                "The `outColor` input (parts kept, or part `emission`).",
            ),
            port::out(
                "outTransparency",
                Type::Color,
                "The `outTransparency` input.",
            ),
            port::out("outGlow", Type::Color, "The `outGlow` input."),
        ],
        lower: lower_surface_shader,
        kind: NodeKind::Shading,
    }
}

fn lower_surface_shader(b: &mut Builder, inp: &NodeInputs) -> Result<Vec<LowVal>, String> {
    let c = inp.low("outColor");
    let out = if c.parts.is_empty() {
        let v = c.value;
        let part = lowering::contribution(b, EMISSION, Type::Color, |_| v);
        lowering::sum_parts(b, Type::Color, vec![part])
    } else {
        c.clone()
    };
    Ok(vec![
        out,
        LowVal::plain(inp.get("outTransparency")),
        LowVal::plain(inp.get("outGlow")),
    ])
}

// ---- lights ----

/// Lights have no outputs: the lowering emits nothing.
fn lower_light(_: &mut Builder, _: &NodeInputs) -> Result<Vec<LowVal>, String> {
    Ok(Vec::new())
}

/// A light node's constant inputs, read by position with the port names for messages.
struct LightArgs<'a> {
    node: &'static str,
    names: &'static [&'static str],
    values: &'a [ConstValue],
}

impl LightArgs<'_> {
    fn value(&self, i: usize) -> Result<&ConstValue, String> {
        let name = self.name(i);
        self.values.get(i).ok_or_else(|| {
            format!(
                "{} expects {} inputs, got {}: `{name}` is missing",
                self.node,
                self.names.len(),
                self.values.len()
            )
        })
    }

    fn name(&self, i: usize) -> &'static str {
        self.names.get(i).copied().unwrap_or("?")
    }

    fn finite(&self, i: usize, x: f64) -> Result<f64, String> {
        if x.is_finite() {
            Ok(x)
        } else {
            Err(format!(
                "input `{}` of {} is not finite ({x})",
                self.name(i),
                self.node
            ))
        }
    }

    fn float(&self, i: usize) -> Result<f64, String> {
        match self.value(i)? {
            ConstValue::Float(x) => self.finite(i, *x),
            ConstValue::Int(k) => Ok(*k as f64),
            other => Err(format!(
                "input `{}` of {} must be a float, got {}",
                self.name(i),
                self.node,
                other.ty()
            )),
        }
    }

    fn triple(&self, i: usize) -> Result<[f64; 3], String> {
        match self.value(i)? {
            ConstValue::Vec3(v) | ConstValue::Color(v) => {
                for x in v {
                    self.finite(i, *x)?;
                }
                Ok(*v)
            }
            ConstValue::Float(x) => {
                let x = self.finite(i, *x)?;
                Ok([x; 3])
            }
            other => Err(format!(
                "input `{}` of {} must be a vec3 or color, got {}",
                self.name(i),
                self.node,
                other.ty()
            )),
        }
    }

    /// A unit direction; the zero vector is an error naming the port.
    /// The light, checked by [`LightDesc::new`]; a rejected field is named by its port
    /// (the power by `intensity`).
    fn build(&self, name: &str, kind: LightKind, power: [f64; 3]) -> Result<LightDesc, String> {
        LightDesc::new(name, kind, power).map_err(|e| {
            let port = match e.field {
                "power" => "intensity",
                "cone_angle" => "coneAngle",
                "penumbra_angle" => "penumbraAngle",
                other => other,
            };
            format!("input `{port}` of {}: {}", self.node, e.reason)
        })
    }

    /// `color · intensity` from the inputs at `color` and `intensity`.
    fn power(&self, color: usize, intensity: usize) -> Result<[f64; 3], String> {
        let c = self.triple(color)?;
        let k = self.float(intensity)?;
        Ok(c.map(|x| x * k))
    }
}

fn color_port() -> super::PortDef {
    port::color("color", [1.0, 1.0, 1.0], "Light color (linear RGB).")
}

const POINT_PORTS: &[&str] = &["color", "intensity", "position"];

fn point_light_def() -> NodeDef {
    NodeDef {
        name: "pointLight",
        category: "light",
        doc: "A point light: radiant intensity `I = color · intensity` [W/sr] emitted \
              equally in all directions from `position` (world space). A point at distance \
              `r` receives `Cl = I / r²` from direction `L = normalize(position − P)`; at \
              `r = 0` it receives 0. `power = color · intensity`. A negative intensity is \
              allowed (a light that removes light, as Maya allows); non-finite inputs are an \
              error naming the port.",
        generic: &[],
        inputs: vec![
            color_port(),
            port::float("intensity", 1.0, "Radiant intensity scale [W/sr]."),
            port::vec3("position", [0.0, 0.0, 0.0], "Position, world space."),
        ],
        outputs: Vec::new(),
        lower: lower_light,
        kind: NodeKind::Light(point_light),
    }
}

/// The [`LightFn`](super::LightFn) of `pointLight`.
fn point_light(name: &str, inputs: &[ConstValue]) -> Result<LightDesc, String> {
    let a = LightArgs {
        node: "pointLight",
        names: POINT_PORTS,
        values: inputs,
    };
    let kind = LightKind::Point {
        position: a.triple(2)?,
    };
    a.build(name, kind, a.power(0, 1)?)
}

const SPOT_PORTS: &[&str] = &[
    "color",
    "intensity",
    "position",
    "direction",
    "coneAngle",
    "penumbraAngle",
    "dropoff",
];

fn spot_light_def() -> NodeDef {
    NodeDef {
        name: "spotLight",
        category: "light",
        doc: "A spot light (Maya): a point light at `position` restricted to a cone around \
              `direction`. With `α` the angle between `direction` and the ray from the light \
              to `P`: `Cl = I / r² · cone(α) · cos(α)^dropoff`, `I = color · intensity` \
              [W/sr]. `cone` is 1 inside the lit cone and 0 outside the dark one, with a \
              smoothstep between: half-angle `h = coneAngle/2`; `penumbraAngle > 0` softens \
              outwards (lit to `h`, dark from `h + penumbraAngle`), `< 0` inwards (lit to \
              `h + penumbraAngle`, dark from `h`), 0 gives a hard edge. `dropoff = 0` turns \
              the `cos^dropoff` falloff off. Angles are given in degrees and stored in \
              radians; `direction` is normalized, and a zero direction is an error. \
              `coneAngle` must lie in [0, 180] and `dropoff` be ≥ 0. `power = color · \
              intensity`; a negative intensity is allowed; non-finite inputs are an error \
              naming the port.",
        generic: &[],
        inputs: vec![
            color_port(),
            port::float("intensity", 1.0, "Radiant intensity scale [W/sr]."),
            port::vec3("position", [0.0, 0.0, 0.0], "Position, world space."),
            port::vec3(
                "direction",
                [0.0, 0.0, -1.0],
                "Direction the spot points in, world space (normalized; must be nonzero).",
            ),
            port::float(
                "coneAngle",
                40.0,
                "Full cone angle in degrees, in [0, 180].",
            ),
            port::float(
                "penumbraAngle",
                0.0,
                "Penumbra width in degrees: > 0 softens outwards, < 0 inwards.",
            ),
            port::float(
                "dropoff",
                0.0,
                "Exponent of `cos` to the axis (≥ 0; 0: no falloff).",
            ),
        ],
        outputs: Vec::new(),
        lower: lower_light,
        kind: NodeKind::Light(spot_light),
    }
}

/// The [`LightFn`](super::LightFn) of `spotLight`.
fn spot_light(name: &str, inputs: &[ConstValue]) -> Result<LightDesc, String> {
    let a = LightArgs {
        node: "spotLight",
        names: SPOT_PORTS,
        values: inputs,
    };
    let kind = LightKind::Spot {
        position: a.triple(2)?,
        direction: a.triple(3)?,
        cone_angle: a.float(4)?.to_radians(),
        penumbra_angle: a.float(5)?.to_radians(),
        dropoff: a.float(6)?,
    };
    a.build(name, kind, a.power(0, 1)?)
}

const DIRECTIONAL_PORTS: &[&str] = &["color", "intensity", "direction"];

fn directional_light_def() -> NodeDef {
    NodeDef {
        name: "directionalLight",
        category: "light",
        doc: "A distant (directional) light: parallel light travelling along `direction`, \
              delivering the irradiance `E = color · intensity` [W/m²] on a surface \
              perpendicular to it. Every point receives `Cl = E` from `L = −direction`. \
              `direction` is normalized; a zero direction is an error. `power = color · \
              intensity`; a negative intensity is allowed; non-finite inputs are an error \
              naming the port.",
        generic: &[],
        inputs: vec![
            color_port(),
            port::float("intensity", 1.0, "Irradiance scale [W/m²]."),
            port::vec3(
                "direction",
                [0.0, 0.0, -1.0],
                "Direction the light travels in, world space (normalized; must be nonzero).",
            ),
        ],
        outputs: Vec::new(),
        lower: lower_light,
        kind: NodeKind::Light(directional_light),
    }
}

/// The [`LightFn`](super::LightFn) of `directionalLight`.
fn directional_light(name: &str, inputs: &[ConstValue]) -> Result<LightDesc, String> {
    let a = LightArgs {
        node: "directionalLight",
        names: DIRECTIONAL_PORTS,
        values: inputs,
    };
    let kind = LightKind::Distant {
        direction: a.triple(2)?,
    };
    a.build(name, kind, a.power(0, 1)?)
}

const AMBIENT_PORTS: &[&str] = &["color", "intensity"];

fn ambient_light_def() -> NodeDef {
    NodeDef {
        name: "ambientLight",
        category: "light",
        doc: "Ambient light: a uniform radiance `La = color · intensity` arriving from every \
              direction, with no direction of its own. It is not part of the light loop; \
              surfaces read the sum of the ambient lights with `ambient()` and reflect it in \
              their `indirect` part (a Lambertian surface reflects `albedo · La`). It also \
              stands for indirect light from photon maps or irradiance caches (thesis \
              §4.3.2). `power = color · intensity`; a negative intensity is allowed; \
              non-finite inputs are an error naming the port.",
        generic: &[],
        inputs: vec![
            color_port(),
            port::float("intensity", 1.0, "Radiance scale."),
        ],
        outputs: Vec::new(),
        lower: lower_light,
        kind: NodeKind::Light(ambient_light),
    }
}

/// The [`LightFn`](super::LightFn) of `ambientLight`.
fn ambient_light(name: &str, inputs: &[ConstValue]) -> Result<LightDesc, String> {
    let a = LightArgs {
        node: "ambientLight",
        names: AMBIENT_PORTS,
        values: inputs,
    };
    a.build(name, LightKind::Ambient, a.power(0, 1)?)
}
