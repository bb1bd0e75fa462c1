//! The shading context: what the renderer tells a material about one fragment.
//!
//! [`Fragment`] is plain `#[repr(C)]` data (the streams, in world space) so compiled back ends
//! can read it at fixed offsets; [`ShadeEnv`] holds what is shared by many fragments (lights,
//! space transforms); [`ShadeCtx`] ties one fragment to its environment and the active
//! render-component mask.

use crate::lights::Light;
use shadenet_graph::ir::{RAY_CAMERA, Space};
use shadenet_graph::nodes::LightDesc;

/// The implicit streams of one fragment, world space (DESIGN §3).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Fragment {
    /// Shading position.
    pub p: [f32; 3],
    /// Shading normal (unit, facing the viewer).
    pub n: [f32; 3],
    /// Geometric normal.
    pub ng: [f32; 3],
    /// Incident direction, eye → P.
    pub i: [f32; 3],
    /// Surface parameterization.
    pub uv: [f32; 2],
    /// ∂P/∂u.
    pub dpdu: [f32; 3],
    /// ∂P/∂v.
    pub dpdv: [f32; 3],
    /// ∂P/∂x (ray differential).
    pub dpdx: [f32; 3],
    /// ∂P/∂y (ray differential).
    pub dpdy: [f32; 3],
    /// Shutter time.
    pub time: f32,
    /// Ray type bit (`shadenet_graph::ir::RAY_CAMERA` …).
    pub ray_type: i32,
    /// Ray depth (0 for camera rays).
    pub ray_depth: i32,
    /// Seed of this fragment's random numbers (area-light and environment samples): the
    /// renderer derives it from pixel and sample index, so images do not depend on threads.
    pub seed: u32,
    /// Four uniform numbers in [0, 1) from the renderer's sampler (the `rand` stream): what
    /// a closure's BSDF sample draws its direction, lobe and Russian roulette from.
    pub rand: [f32; 4],
}

/// A rigid or affine transform with its inverse, row-major 4×4.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// world → space.
    pub m: [f64; 16],
    /// space → world.
    pub inv: [f64; 16],
}

impl Transform {
    /// The identity.
    pub const IDENTITY: Transform = Transform {
        m: IDENTITY,
        inv: IDENTITY,
    };

    /// A transform from its matrix; `None` if the matrix is singular or not finite.
    pub fn new(m: [f64; 16]) -> Option<Transform> {
        invert(&m).map(|inv| Transform { m, inv })
    }

    /// A look-at camera transform: world → camera space, the eye at the origin looking down
    /// −z with `up` as +y.
    pub fn look_at(eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> Option<Transform> {
        let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let norm = |v: [f64; 3]| {
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            (l > 0.0).then(|| [v[0] / l, v[1] / l, v[2] / l])
        };
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let f = norm(sub(target, eye))?;
        let r = norm(cross(f, up))?;
        let u = cross(r, f);
        let m = [
            r[0],
            r[1],
            r[2],
            -dot(r, eye), //
            u[0],
            u[1],
            u[2],
            -dot(u, eye), //
            -f[0],
            -f[1],
            -f[2],
            dot(f, eye), //
            0.0,
            0.0,
            0.0,
            1.0,
        ];
        Transform::new(m)
    }
}

const IDENTITY: [f64; 16] = [
    1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
];

/// Inverts a 4×4 matrix (Gauss–Jordan with partial pivoting); `None` if singular or not
/// finite.
pub fn invert(m: &[f64; 16]) -> Option<[f64; 16]> {
    if m.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let mut a = *m;
    let mut inv = IDENTITY;
    for col in 0..4 {
        let pivot =
            (col..4).max_by(|&i, &j| a[i * 4 + col].abs().total_cmp(&a[j * 4 + col].abs()))?;
        if a[pivot * 4 + col].abs() < 1e-300 {
            return None;
        }
        for k in 0..4 {
            a.swap(col * 4 + k, pivot * 4 + k);
            inv.swap(col * 4 + k, pivot * 4 + k);
        }
        let d = a[col * 4 + col];
        for k in 0..4 {
            a[col * 4 + k] /= d;
            inv[col * 4 + k] /= d;
        }
        for row in 0..4 {
            if row != col {
                let f = a[row * 4 + col];
                for k in 0..4 {
                    a[row * 4 + k] -= f * a[col * 4 + k];
                    inv[row * 4 + k] -= f * inv[col * 4 + k];
                }
            }
        }
    }
    Some(inv)
}

/// What many fragments share: the light list and the space transforms.
#[derive(Clone, Debug)]
pub struct ShadeEnv {
    /// Lights, world space.
    pub lights: Vec<Light>,
    /// world → camera.
    pub camera: Transform,
    /// world → object (of the shaded object).
    pub object: Transform,
}

impl Default for ShadeEnv {
    fn default() -> Self {
        ShadeEnv {
            lights: Vec::new(),
            camera: Transform::IDENTITY,
            object: Transform::IDENTITY,
        }
    }
}

impl ShadeEnv {
    /// An environment with these lights and identity transforms.
    pub fn with_lights(lights: &[LightDesc]) -> ShadeEnv {
        ShadeEnv {
            lights: lights.iter().map(Light::from_desc).collect(),
            ..ShadeEnv::default()
        }
    }

    /// The transform world → `space` (`None` for world).
    pub fn transform(&self, space: Space) -> Option<&Transform> {
        match space {
            Space::World => None,
            Space::Camera => Some(&self.camera),
            Space::Object => Some(&self.object),
        }
    }
}

/// What [`SceneServices::probe`] found: the closest surface along a ray, unshaded.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProbeHit {
    /// The distance along the ray from its origin.
    pub distance: f32,
    /// The point hit.
    pub p: [f32; 3],
    /// The unit shading normal there (interpolated vertex normals, or the geometric one),
    /// as the surface's winding gives it (not turned towards the ray).
    pub n: [f32; 3],
    /// The unit geometric normal, by the winding.
    pub ng: [f32; 3],
    /// The surface's texture coordinates there.
    pub uv: [f32; 2],
}

/// What a renderer offers shaders: secondary rays (DESIGN §2). The tracer implements it;
/// back ends call it for the ops that trace and for light visibility. The shading system
/// never sees the scene itself.
///
/// Each method must be a pure function of its arguments (and the scene): back ends may call
/// it once where a program asks twice (the interpreter asks `occluded` once per light sample
/// and shading call, however many light loops read the sample's visibility). Directions and
/// normals passed in are unit and finite.
pub trait SceneServices: Send + Sync {
    /// Radiance arriving at `origin` from direction `dir` (unit): the renderer traces the ray
    /// and shades what it hits as a ray of type `ray_type` (`RAY_*`) at depth `depth`; black
    /// past its depth limits or when the ray escapes to an environment without light.
    /// `bsdf_pdf > 0`: the direction was drawn by BSDF sampling with that solid-angle
    /// density, and light sources the ray reaches directly (area lights, the environment)
    /// count with the power-heuristic weight against the light loop's samples of them (which
    /// the shader weights the other way); `0`: they count in full.
    fn trace(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        ray_type: i32,
        depth: i32,
        bsdf_pdf: f32,
    ) -> [f32; 3];
    /// Whether anything blocks the segment from `from` to `to` (shadow rays; a distant
    /// light's `to` is far along its direction).
    fn occluded(&self, from: [f32; 3], to: [f32; 3]) -> bool;
    /// Ambient occlusion at `p` around normal `n`: the fraction of `samples` cosine-weighted
    /// directions that reach `max_distance` unblocked, in [0, 1], deterministic in `seed`.
    fn occlusion(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        samples: u32,
        max_distance: f32,
        seed: u32,
    ) -> f32;

    /// The value of the shading program's geometry attribute `slot` (an index into its
    /// `Program::attributes`, resolved by the renderer to one of the hit geometry's
    /// attributes once per program and geometry) at this fragment: `out.len()` floats (1 to
    /// 4, the type's width) interpolated at the hit. `false` (the default) where the
    /// geometry has no such attribute, or for services that belong to no hit: the shader
    /// then uses the attribute op's default. Back ends call it only through
    /// `shadenet_runtime::interp::attribute_value` and `attribute_found`.
    fn attribute(&self, slot: u32, out: &mut [f32]) -> bool {
        let _ = (slot, out);
        false
    }

    /// The closest surface along the ray from `origin` in direction `dir` (unit) at a
    /// distance in `[min_distance, max_distance]`, without shading it (OSL's `trace`): the
    /// ray starts from the fragment's point as `trace` does (offset off the surface), and
    /// `None` (the default) where it hits nothing or there is no scene. Back ends call it
    /// only through `shadenet_runtime::interp::probe_field`.
    fn probe(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        min_distance: f32,
        max_distance: f32,
    ) -> Option<ProbeHit> {
        let _ = (origin, dir, min_distance, max_distance);
        None
    }

    /// The services of fragment `index` of the batch a `Material::shade_many` call shades
    /// with these services, for a renderer whose services carry per-hit state (the tracer's:
    /// the hit's point, facing normals, seed and ray differentials). `None` (the default):
    /// these services serve every fragment alike. Every back end's `shade_many` asks for
    /// fragment `i`'s services ([`fragment_services`]) before it traces, tests visibility or
    /// samples occlusion for it (the default `shade_many` and the GPU's host steps do); the batch's own methods
    /// then serve only rays that belong to no fragment of the batch.
    fn fragment(&self, index: usize) -> Option<&dyn SceneServices> {
        let _ = index;
        None
    }
}

/// The services of fragment `index` of a batch shaded with `scene`: its own where the
/// renderer gives per-fragment services ([`SceneServices::fragment`]), else the batch's.
/// Every back end's `shade_many` asks through this before it traces, tests visibility or
/// samples occlusion for a fragment.
pub fn fragment_services(
    scene: Option<&dyn SceneServices>,
    index: usize,
) -> Option<&dyn SceneServices> {
    scene.map(|s| s.fragment(index).unwrap_or(s))
}

/// One shading call's input: the fragment, its environment, the active components and the
/// renderer's services.
#[derive(Clone, Copy)]
pub struct ShadeCtx<'a> {
    /// The fragment's streams.
    pub frag: Fragment,
    /// Lights and transforms.
    pub env: &'a ShadeEnv,
    /// Active render components: bit `i` is `Program::components[i]`.
    pub mask: u32,
    /// Secondary rays, when a renderer provides them (`None`: traced rays return black and
    /// nothing is occluded).
    pub scene: Option<&'a dyn SceneServices>,
}

impl std::fmt::Debug for ShadeCtx<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShadeCtx")
            .field("frag", &self.frag)
            .field("env", &self.env)
            .field("mask", &self.mask)
            .field("scene", &self.scene.is_some())
            .finish()
    }
}

impl<'a> ShadeCtx<'a> {
    /// A camera-ray context with every component active.
    pub fn new(frag: Fragment, env: &'a ShadeEnv) -> ShadeCtx<'a> {
        let mut frag = frag;
        if frag.ray_type == 0 {
            frag.ray_type = RAY_CAMERA;
        }
        ShadeCtx {
            frag,
            env,
            mask: u32::MAX,
            scene: None,
        }
    }
}
