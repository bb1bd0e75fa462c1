//! Closures as compile-time lobe lists (DESIGN §12).
//!
//! A `BSDF` or `EDF` value never exists at run time. Lowering a closure node yields a
//! [`Closure`]: a list of [`Lobe`]s, each a lobe kind with the IR values of its parameters,
//! a color weight, its shading frame and its render component. `mix`, `add`, `multiply` and
//! `layer` are list operations done while lowering ([`list`]), so a lobe whose weight folds
//! to 0 costs nothing once the partial evaluator has run.
//!
//! Every lobe kind has one file that emits IR for three functions, all in the lobe's local
//! frame (`z` = the shading normal turned towards the viewer, see [`frame`]) with unit
//! directions `wo` (towards the viewer) and `wi` (towards the light):
//! - `eval(wo, wi) → (f · |cos θi|, pdf)`: the cosine-weighted BSDF and the solid-angle
//!   density with which `sample` picks `wi`;
//! - `sample(wo, u) → (wi, weight, pdf)`: a direction drawn from three uniform numbers `u`
//!   (vec3 in [0, 1)), with `weight = f · |cos θi| / pdf` (0 where `pdf = 0`);
//! - `albedo(wo)`: the directional albedo, `∫ f · |cos θi| dwi` (exact or a documented fit),
//!   which `layer` uses to scale the base and the closure uses to pick a lobe to sample.
//!
//! The lobe's weight is not part of these: [`list`] applies it. Lobe files must not read
//! streams or lights (the surface lowering does) nor touch other lobes' parameters.
//!
//! This module owns the lobe data types, the frame and the dispatch; it must not know about
//! MaterialX nodes (the atoms in `crate::mtlx` build lobes) or the light loop.

pub mod blinn;
pub mod burley;
pub mod conductor;
pub mod dielectric;
pub mod frame;
pub mod ggx;
pub mod list;
pub mod math;
pub mod oren_nayar;
pub mod phong;
pub mod probe;
pub mod schlick;
pub mod shade;
pub mod sheen;
pub mod subsurface;
pub mod thin_film;
pub mod translucent;

pub use frame::Frame;
pub use list::Closure;

use crate::ir::{Builder, Value};

/// How a lobe scatters light: reflection, transmission or both (MaterialX `scatter_mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScatterMode {
    /// Reflection only (`R`).
    R,
    /// Transmission only (`T`).
    T,
    /// Reflection and transmission (`RT`).
    RT,
}

impl ScatterMode {
    /// The mode named `s` (`R`, `T`, `RT`), as MaterialX writes it.
    pub fn from_name(s: &str) -> Option<ScatterMode> {
        match s {
            "R" => Some(ScatterMode::R),
            "T" => Some(ScatterMode::T),
            "RT" => Some(ScatterMode::RT),
            _ => None,
        }
    }
}

/// A thin film on top of a specular lobe (MaterialX `thinfilm_thickness`, `thinfilm_ior`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinFilm {
    /// Thickness in nanometres (float); 0 disables the film.
    pub thickness: Value,
    /// The film's index of refraction (float).
    pub ior: Value,
}

/// A lobe kind and the IR values of its parameters (before its frame and weight).
#[derive(Clone, Debug, PartialEq)]
pub enum LobeKind {
    /// `oren_nayar_diffuse_bsdf`: diffuse reflection of albedo `color` (color) and Oren–Nayar
    /// `roughness` (float, 0 = Lambert); `energy_compensation` adds the multiple scattering
    /// of MaterialX 1.39 (Fujii's energy-preserving variant). See [`oren_nayar`].
    OrenNayar {
        /// Albedo (color).
        color: Value,
        /// Roughness σ (float).
        roughness: Value,
        /// Whether to add the energy lost to single scattering back.
        energy_compensation: bool,
    },
    /// `burley_diffuse_bsdf`: Burley's diffuse reflection of `color` (color) with `roughness`
    /// (float). See [`burley`].
    Burley {
        /// Albedo (color).
        color: Value,
        /// Roughness (float).
        roughness: Value,
    },
    /// `translucent_bsdf`: Lambertian transmission of `color` (color) to the side opposite
    /// the viewer. See [`translucent`].
    Translucent {
        /// Transmittance (color).
        color: Value,
    },
    /// `sheen_bsdf` in mode `conty_kulla`: the Imageworks sheen of `color` (color) and
    /// `roughness` (float). See [`sheen`].
    Sheen {
        /// Sheen color (color).
        color: Value,
        /// Roughness (float).
        roughness: Value,
    },
    /// `subsurface_bsdf`, approximated by Lambertian reflection of `color` until volumes
    /// exist (`radius` and `anisotropy` are ignored). See [`subsurface`].
    Subsurface {
        /// Albedo (color).
        color: Value,
        /// Mean free path (color); unused by the approximation.
        radius: Value,
        /// Phase-function anisotropy (float); unused by the approximation.
        anisotropy: Value,
    },
    /// `dielectric_bsdf`: a rough GGX dielectric interface. See [`dielectric`].
    Dielectric {
        /// Tint (color).
        tint: Value,
        /// Index of refraction (float).
        ior: Value,
        /// Roughness `(αx, αy)` (vec2), clamped to [`ggx::ALPHA_MIN`, 1].
        roughness: Value,
        /// Reflection, transmission or both.
        scatter_mode: ScatterMode,
        /// A thin film on the interface ([`thin_film`]); `None` where its thickness is 0.
        thin_film: Option<ThinFilm>,
    },
    /// `conductor_bsdf`: a rough GGX metal with the exact complex Fresnel. See
    /// [`conductor`].
    Conductor {
        /// Index of refraction `n` (color).
        ior: Value,
        /// Extinction `k` (color).
        extinction: Value,
        /// Roughness `(αx, αy)` (vec2).
        roughness: Value,
        /// A thin film on the metal ([`thin_film`]); `None` where its thickness is 0.
        thin_film: Option<ThinFilm>,
    },
    /// `generalized_schlick_bsdf`: a rough GGX interface with the F82-tinted generalized
    /// Schlick Fresnel. See [`schlick`].
    GeneralizedSchlick {
        /// Reflectance at normal incidence (color).
        color0: Value,
        /// Reflectance tint at 82° (color).
        color82: Value,
        /// Reflectance at grazing incidence (color).
        color90: Value,
        /// Schlick exponent (float).
        exponent: Value,
        /// Roughness `(αx, αy)` (vec2).
        roughness: Value,
        /// Reflection, transmission or both.
        scatter_mode: ScatterMode,
        /// A thin film on the interface ([`thin_film`]); `None` where its thickness is 0.
        thin_film: Option<ThinFilm>,
    },
    /// The normalized modified Phong lobe of Maya's `phong`: `color · (n+2)/(2π) · cosⁿα`
    /// about the mirror direction. See [`phong`].
    Phong {
        /// Specular color `ks` (the albedo at normal incidence).
        color: Value,
        /// Exponent `n` (float), clamped to [0, [`phong::MAX_EXPONENT`]].
        exponent: Value,
    },
    /// The normalized Blinn–Phong half-vector lobe of Maya's `blinn`, with a Schlick
    /// roll-off. See [`blinn`].
    Blinn {
        /// Specular color `ks`.
        color: Value,
        /// Exponent `n` (float), clamped to [0, [`phong::MAX_EXPONENT`]].
        exponent: Value,
        /// Reflectance at normal incidence relative to grazing (float, clamped to [0, 1];
        /// 1 turns the roll-off off).
        rolloff: Value,
    },
}

/// One lobe of a closure: its kind and parameters, the color weight the closure gives it,
/// the frame it lives in and the render component its light belongs to.
#[derive(Clone, Debug, PartialEq)]
pub struct Lobe {
    /// Kind and parameters.
    pub kind: LobeKind,
    /// Weight (color), the product of every `mix`/`multiply`/`layer` factor above it.
    pub weight: Value,
    /// The shading frame.
    pub frame: Frame,
    /// The render component (`diffuse`, `specular`, `transmission`, `sheen`, `coat`; Phong
    /// and Blinn lobes are `specular`).
    pub component: &'static str,
    /// Why the lobe cannot be built as its node asks (a feature no lobe models yet, e.g.
    /// retroreflection), or `None`. Such a lobe must specialize away: at the
    /// material output its weight has to be the constant 0 (it is then dropped,
    /// [`Closure::without_unbuilt`]), else compiling fails with this reason.
    pub unbuilt: Option<String>,
}

/// A lobe's cosine-weighted value and its sampling density for one pair of directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Eval {
    /// `f(wo, wi) · |cos θi|` (color).
    pub value: Value,
    /// Solid-angle density of `wi` under the lobe's `sample` (float).
    pub pdf: Value,
}

/// A direction drawn by a lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// The sampled direction `wi` (vec3, unit, local frame for lobe files, world space for
    /// [`Closure::sample`]).
    pub wi: Value,
    /// `f · |cos θi| / pdf` (color; 0 where `pdf = 0`).
    pub weight: Value,
    /// Solid-angle density of `wi` (float).
    pub pdf: Value,
}

impl LobeKind {
    /// Whether the lobe scatters diffusely (its sampled rays are `diffuse` rays, with the
    /// diffuse depth limit); glossy and specular lobes' are reflection or refraction rays.
    pub fn is_diffuse(&self) -> bool {
        match self {
            LobeKind::OrenNayar { .. }
            | LobeKind::Burley { .. }
            | LobeKind::Translucent { .. }
            | LobeKind::Sheen { .. }
            | LobeKind::Subsurface { .. } => true,
            LobeKind::Dielectric { .. }
            | LobeKind::Conductor { .. }
            | LobeKind::GeneralizedSchlick { .. }
            | LobeKind::Phong { .. }
            | LobeKind::Blinn { .. } => false,
        }
    }

    /// The lobe's `eval` in its local frame (`wo`, `wi` unit vec3), the viewer outside.
    pub fn eval(&self, b: &mut Builder, wo: Value, wi: Value) -> Eval {
        let outside = b.boolean(false);
        self.eval_sided(b, outside, wo, wi)
    }

    /// The lobe's `sample` in its local frame (`u` a vec3 of uniform numbers), the viewer
    /// outside.
    pub fn sample(&self, b: &mut Builder, wo: Value, u: Value) -> Sample {
        let outside = b.boolean(false);
        self.sample_sided(b, outside, wo, u)
    }

    /// The lobe's directional albedo for `wo` (local frame), a color, the viewer outside.
    pub fn albedo(&self, b: &mut Builder, wo: Value) -> Value {
        let outside = b.boolean(false);
        self.albedo_sided(b, outside, wo)
    }

    /// [`LobeKind::eval`] with `inside` (bool, [`Frame::inside`]) saying whether the viewer
    /// is inside (transmitting lobes swap their indices).
    pub fn eval_sided(&self, b: &mut Builder, inside: Value, wo: Value, wi: Value) -> Eval {
        self.resolve(inside).eval(b, wo, wi)
    }

    /// [`LobeKind::sample`] with `inside` as in [`LobeKind::eval_sided`].
    pub fn sample_sided(&self, b: &mut Builder, inside: Value, wo: Value, u: Value) -> Sample {
        self.resolve(inside).sample(b, wo, u)
    }

    /// [`LobeKind::albedo`] with `inside` as in [`LobeKind::eval_sided`].
    pub fn albedo_sided(&self, b: &mut Builder, inside: Value, wo: Value) -> Value {
        self.resolve(inside).albedo(b, wo)
    }

    /// The kind's parameters with the viewer's side where the lobe needs it.
    fn resolve(&self, inside: Value) -> Resolved {
        match *self {
            LobeKind::OrenNayar { .. }
            | LobeKind::Burley { .. }
            | LobeKind::Translucent { .. }
            | LobeKind::Sheen { .. }
            | LobeKind::Subsurface { .. }
            | LobeKind::Phong { .. }
            | LobeKind::Blinn { .. } => Resolved::Diffuse(self.clone()),
            LobeKind::Dielectric {
                tint,
                ior,
                roughness,
                scatter_mode,
                thin_film,
            } => Resolved::Dielectric(dielectric::Dielectric {
                tint,
                ior,
                roughness,
                mode: scatter_mode,
                inside,
                thin_film,
            }),
            LobeKind::Conductor {
                ior,
                extinction,
                roughness,
                thin_film,
            } => Resolved::Conductor(conductor::Conductor {
                ior,
                extinction,
                roughness,
                thin_film,
            }),
            LobeKind::GeneralizedSchlick {
                color0,
                color82,
                color90,
                exponent,
                roughness,
                scatter_mode,
                thin_film,
            } => Resolved::Schlick(schlick::Schlick {
                color0,
                color82,
                color90,
                exponent,
                roughness,
                mode: scatter_mode,
                inside,
                thin_film,
            }),
        }
    }
}

/// A lobe kind's parameters ready to emit, the viewer's side included.
enum Resolved {
    /// A lobe that does not depend on the viewer's side (the diffuse family, Phong, Blinn).
    Diffuse(LobeKind),
    Dielectric(dielectric::Dielectric),
    Conductor(conductor::Conductor),
    Schlick(schlick::Schlick),
}

impl Resolved {
    fn eval(&self, b: &mut Builder, wo: Value, wi: Value) -> Eval {
        match self {
            Resolved::Diffuse(k) => diffuse_eval(b, k, wo, wi),
            Resolved::Dielectric(l) => l.eval(b, wo, wi),
            Resolved::Conductor(l) => l.eval(b, wo, wi),
            Resolved::Schlick(l) => l.eval(b, wo, wi),
        }
    }

    fn sample(&self, b: &mut Builder, wo: Value, u: Value) -> Sample {
        match self {
            Resolved::Diffuse(k) => diffuse_sample(b, k, wo, u),
            Resolved::Dielectric(l) => l.sample(b, wo, u),
            Resolved::Conductor(l) => l.sample(b, wo, u),
            Resolved::Schlick(l) => l.sample(b, wo, u),
        }
    }

    fn albedo(&self, b: &mut Builder, wo: Value) -> Value {
        match self {
            Resolved::Diffuse(k) => diffuse_albedo(b, k, wo),
            Resolved::Dielectric(l) => l.albedo(b, wo),
            Resolved::Conductor(l) => l.albedo(b, wo),
            Resolved::Schlick(l) => l.albedo(b, wo),
        }
    }
}

/// `eval` of a side-independent lobe (the diffuse family, Phong, Blinn).
fn diffuse_eval(b: &mut Builder, k: &LobeKind, wo: Value, wi: Value) -> Eval {
    match *k {
        LobeKind::OrenNayar {
            color,
            roughness,
            energy_compensation,
        } => oren_nayar::eval(b, color, roughness, energy_compensation, wo, wi),
        LobeKind::Burley { color, roughness } => burley::eval(b, color, roughness, wo, wi),
        LobeKind::Translucent { color } => translucent::eval(b, color, wo, wi),
        LobeKind::Sheen { color, roughness } => sheen::eval(b, color, roughness, wo, wi),
        LobeKind::Subsurface { color, .. } => subsurface::eval(b, color, wo, wi),
        LobeKind::Phong { color, exponent } => phong::eval(b, color, exponent, wo, wi),
        LobeKind::Blinn {
            color,
            exponent,
            rolloff,
        } => blinn::eval(b, color, exponent, rolloff, wo, wi),
        _ => unreachable!("resolve() sends only the diffuse family here"),
    }
}

/// `sample` of a side-independent lobe (the diffuse family, Phong, Blinn).
fn diffuse_sample(b: &mut Builder, k: &LobeKind, wo: Value, u: Value) -> Sample {
    match *k {
        LobeKind::OrenNayar {
            color,
            roughness,
            energy_compensation,
        } => oren_nayar::sample(b, color, roughness, energy_compensation, wo, u),
        LobeKind::Burley { color, roughness } => burley::sample(b, color, roughness, wo, u),
        LobeKind::Translucent { color } => translucent::sample(b, color, wo, u),
        LobeKind::Sheen { color, roughness } => sheen::sample(b, color, roughness, wo, u),
        LobeKind::Subsurface { color, .. } => subsurface::sample(b, color, wo, u),
        LobeKind::Phong { color, exponent } => phong::sample(b, color, exponent, wo, u),
        LobeKind::Blinn {
            color,
            exponent,
            rolloff,
        } => blinn::sample(b, color, exponent, rolloff, wo, u),
        _ => unreachable!("resolve() sends only the diffuse family here"),
    }
}

/// `albedo` of a side-independent lobe (the diffuse family, Phong, Blinn).
fn diffuse_albedo(b: &mut Builder, k: &LobeKind, wo: Value) -> Value {
    match *k {
        LobeKind::OrenNayar {
            color,
            roughness,
            energy_compensation,
        } => oren_nayar::albedo(b, color, roughness, energy_compensation, wo),
        LobeKind::Burley { color, roughness } => burley::albedo(b, color, roughness, wo),
        LobeKind::Translucent { color } => translucent::albedo(b, color, wo),
        LobeKind::Sheen { color, roughness } => sheen::albedo(b, color, roughness, wo),
        LobeKind::Subsurface { color, .. } => subsurface::albedo(b, color, wo),
        LobeKind::Phong { color, exponent } => phong::albedo(b, color, exponent, wo),
        LobeKind::Blinn {
            color,
            exponent,
            rolloff,
        } => blinn::albedo(b, color, exponent, rolloff, wo),
        _ => unreachable!("resolve() sends only the diffuse family here"),
    }
}
