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

pub mod burley;
pub mod frame;
pub mod list;
pub mod math;
pub mod oren_nayar;
pub mod shade;
pub mod sheen;
pub mod subsurface;
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
    /// The render component (`diffuse`, `specular`, `transmission`, `sheen`, `coat`).
    pub component: &'static str,
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
        }
    }

    /// The lobe's `eval` in its local frame (`wo`, `wi` unit vec3).
    pub fn eval(&self, b: &mut Builder, wo: Value, wi: Value) -> Eval {
        match self {
            LobeKind::OrenNayar {
                color,
                roughness,
                energy_compensation,
            } => oren_nayar::eval(b, *color, *roughness, *energy_compensation, wo, wi),
            LobeKind::Burley { color, roughness } => burley::eval(b, *color, *roughness, wo, wi),
            LobeKind::Translucent { color } => translucent::eval(b, *color, wo, wi),
            LobeKind::Sheen { color, roughness } => sheen::eval(b, *color, *roughness, wo, wi),
            LobeKind::Subsurface { color, .. } => subsurface::eval(b, *color, wo, wi),
        }
    }

    /// The lobe's `sample` in its local frame (`u` a vec3 of uniform numbers).
    pub fn sample(&self, b: &mut Builder, wo: Value, u: Value) -> Sample {
        match self {
            LobeKind::OrenNayar {
                color,
                roughness,
                energy_compensation,
            } => oren_nayar::sample(b, *color, *roughness, *energy_compensation, wo, u),
            LobeKind::Burley { color, roughness } => burley::sample(b, *color, *roughness, wo, u),
            LobeKind::Translucent { color } => translucent::sample(b, *color, wo, u),
            LobeKind::Sheen { color, roughness } => sheen::sample(b, *color, *roughness, wo, u),
            LobeKind::Subsurface { color, .. } => subsurface::sample(b, *color, wo, u),
        }
    }

    /// The lobe's directional albedo for `wo` (local frame), a color.
    pub fn albedo(&self, b: &mut Builder, wo: Value) -> Value {
        match self {
            LobeKind::OrenNayar {
                color,
                roughness,
                energy_compensation,
            } => oren_nayar::albedo(b, *color, *roughness, *energy_compensation, wo),
            LobeKind::Burley { color, roughness } => burley::albedo(b, *color, *roughness, wo),
            LobeKind::Translucent { color } => translucent::albedo(b, *color, wo),
            LobeKind::Sheen { color, roughness } => sheen::albedo(b, *color, *roughness, wo),
            LobeKind::Subsurface { color, .. } => subsurface::albedo(b, *color, wo),
        }
    }
}
