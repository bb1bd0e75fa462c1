//! The scene file (TOML): its data model, parsing and validation.
//!
//! `docs/scene-format.md` is the user's reference; this module is its implementation. Every
//! table rejects unknown keys (`deny_unknown_fields`), and every error names the key (and
//! the file) it is about. Loading a scene reads its meshes (OBJ, glTF or built-in shapes),
//! checks its transforms, lights and render settings, and resolves material references to
//! a [`MaterialSource`] — compiling a material's network is the caller's business (the
//! tracer never sees nodes).

use crate::geometry::{self, Mesh};
use crate::passes::{PassDef, PassKind, RayMatch, Rule, RuleAction};
use glam::{DMat4, DVec3};
use serde::Deserialize;
use shadenet_graph::LightStrategy;
use shadenet_graph::nodes::env_image::EnvImage;
use shadenet_graph::nodes::{LightDesc, LightKind};
use shadenet_runtime::input::{self, FileKind, InputError};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A scene that cannot be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file could not be read (missing, not a regular file, over the size limit
    /// for text files, not UTF-8): the input gate's error says which, naming the file.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The file is not valid TOML or not of the expected shape (the message names the key
    /// and its line).
    #[error("{}: {message}", path.display())]
    Syntax {
        /// The file.
        path: PathBuf,
        /// toml's message: line, column, key.
        message: String,
    },
    /// A value is invalid.
    #[error("{}: `{key}`: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The key, as a dotted path (`instances[2].rotate`).
        key: String,
        /// What is wrong.
        message: String,
    },
    /// An environment map could not be loaded.
    #[error("{}: `{key}`: cannot load environment map {}: {message}", path.display(), file.display())]
    EnvMap {
        /// The scene file.
        path: PathBuf,
        /// The key naming the map (`lights[i].map`).
        key: String,
        /// The map file.
        file: PathBuf,
        /// Why.
        message: String,
    },
    /// A mesh file could not be loaded.
    #[error("{}: `{key}`: cannot load mesh {}: {message}", path.display(), file.display())]
    Mesh {
        /// The scene file.
        path: PathBuf,
        /// The key naming the mesh.
        key: String,
        /// The mesh file.
        file: PathBuf,
        /// Why.
        message: String,
    },
}

// ---------------------------------------------------------------------------------------
// Ranges (docs/scene-format.md lists each; a value beyond its range is an error naming the
// key, never clamped)
// ---------------------------------------------------------------------------------------

pub use crate::geometry::MAX_COORDINATE;

/// `render.spp`: 1 to this.
pub const MAX_SPP: u32 = 1 << 16;
/// `render.max_*_depth` and the rules' `depth`/`min_depth`/`max_depth`: 0 to this.
pub const MAX_DEPTH: u32 = 64;
/// `render.tile_size`: 1 to this.
pub const MAX_TILE_SIZE: u32 = 1024;
/// `render.occlusion_samples`: 1 to this.
pub const MAX_OCCLUSION_SAMPLES: u32 = 1 << 16;
/// `camera.resolution`: each side 1 to this.
pub const MAX_RESOLUTION: u32 = 16384;
/// A sphere's `segments`: 3 to this.
pub const MAX_SEGMENTS: u32 = 4096;
/// `render.filter_width`, in pixels: above 0, at most this.
pub const MAX_FILTER_WIDTH: f64 = 16.0;

/// The message for a coordinate beyond [`MAX_COORDINATE`].
fn out_of_range(x: f64) -> String {
    format!("{x:e} is {}", beyond_range())
}

fn beyond_range() -> String {
    format!(
        "outside the supported coordinate range ±{MAX_COORDINATE:e} \
         (docs/scene-format.md, \"Coordinates\")"
    )
}

// ---------------------------------------------------------------------------------------
// The file, as written
// ---------------------------------------------------------------------------------------

/// The scene file as written (see `docs/scene-format.md`).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// The camera.
    pub camera: CameraSpec,
    /// Render settings.
    #[serde(default)]
    pub render: RenderSpec,
    /// Materials by name.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    /// Meshes by name.
    #[serde(default)]
    pub meshes: BTreeMap<String, MeshSpec>,
    /// Placed meshes.
    #[serde(default)]
    pub instances: Vec<InstanceSpec>,
    /// Lights.
    #[serde(default)]
    pub lights: Vec<LightSpec>,
}

/// `[camera]`: a pinhole perspective camera.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Eye position.
    pub position: [f64; 3],
    /// The point looked at.
    pub look_at: [f64; 3],
    /// Up direction (default +y).
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// Vertical field of view, degrees (default 45).
    #[serde(default = "default_fov")]
    pub fov: f64,
    /// Image size `[width, height]` in pixels (default 320×240).
    #[serde(default = "default_resolution")]
    pub resolution: [u32; 2],
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    45.0
}
fn default_resolution() -> [u32; 2] {
    [320, 240]
}

/// `[render]`: sampling, depth limits, passes and ray-match rules.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSpec {
    /// Samples per pixel.
    #[serde(default = "one")]
    pub spp: u32,
    /// Reflection rays deeper than this return black.
    #[serde(default = "four")]
    pub max_reflection_depth: u32,
    /// Refraction rays deeper than this return black.
    #[serde(default = "six")]
    pub max_refraction_depth: u32,
    /// Diffuse (indirect) rays deeper than this return black.
    #[serde(default = "one")]
    pub max_diffuse_depth: u32,
    /// Passes by standard name: a render component or an override pass.
    #[serde(default)]
    pub passes: Vec<String>,
    /// Custom passes: `[[render.pass]]`.
    #[serde(default)]
    pub pass: Vec<PassSpec>,
    /// Ray-match rules, first match wins: `[[render.rules]]`.
    #[serde(default)]
    pub rules: Vec<RuleSpec>,
    /// Rays per shaded point of the `occlusion` override pass.
    #[serde(default = "sixteen")]
    pub occlusion_samples: u32,
    /// Distance beyond which geometry does not occlude (the `occlusion` override pass).
    #[serde(default = "default_occlusion_distance")]
    pub occlusion_distance: f64,
    /// Tile edge in pixels.
    #[serde(default = "sixteen")]
    pub tile_size: u32,
    /// The pixel filter: `box` (default), `gaussian` or `blackman-harris`.
    #[serde(default)]
    pub filter: Option<String>,
    /// The pixel filter's full width in pixels (default 1 for `box`, 3 for the others).
    #[serde(default)]
    pub filter_width: Option<f64>,
    /// How closures gather area lights and the environment: `mis` (default), `light` or
    /// `bsdf` ([`LightStrategy`]).
    #[serde(default)]
    pub light_strategy: Option<String>,
}

impl Default for RenderSpec {
    fn default() -> Self {
        RenderSpec {
            spp: 1,
            max_reflection_depth: 4,
            max_refraction_depth: 6,
            max_diffuse_depth: 1,
            passes: Vec::new(),
            pass: Vec::new(),
            rules: Vec::new(),
            occlusion_samples: 16,
            occlusion_distance: default_occlusion_distance(),
            tile_size: 16,
            filter: None,
            filter_width: None,
            light_strategy: None,
        }
    }
}

fn one() -> u32 {
    1
}
fn four() -> u32 {
    4
}
fn six() -> u32 {
    6
}
fn sixteen() -> u32 {
    16
}
fn default_occlusion_distance() -> f64 {
    1.0
}

/// `[[render.pass]]`: a named pass summing components, or an override pass.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PassSpec {
    /// The layer name in the EXR.
    pub name: String,
    /// Components summed into this pass.
    #[serde(default)]
    pub components: Option<Vec<String>>,
    /// An override shader instead: `normal`, `depth`, `uv` or `occlusion`.
    #[serde(default, rename = "override")]
    pub override_: Option<String>,
}

/// `[[render.rules]]`: what hits of matching rays shade.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RuleSpec {
    /// Ray type: `camera`, `reflection`, `refraction`, `diffuse` or `any` (default).
    #[serde(default)]
    pub ray: Option<String>,
    /// Exactly this depth.
    #[serde(default)]
    pub depth: Option<u32>,
    /// At least this depth.
    #[serde(default)]
    pub min_depth: Option<u32>,
    /// At most this depth.
    #[serde(default)]
    pub max_depth: Option<u32>,
    /// Components the hit computes (`["all"]` for every one).
    #[serde(default)]
    pub components: Option<Vec<String>>,
    /// Replace the material with an override shader.
    #[serde(default, rename = "override")]
    pub override_: Option<String>,
}

/// `[materials.NAME]`: a network file, a MaterialX document, or an inline network, with
/// parameter overrides.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// A network file, relative to the scene file.
    #[serde(default)]
    pub network: Option<String>,
    /// A MaterialX document (`.mtlx`), relative to the scene file.
    #[serde(default)]
    pub mtlx: Option<String>,
    /// With `mtlx`: the document's material to use (closures: not built yet, issue 15).
    #[serde(default)]
    pub material: Option<String>,
    /// With `mtlx`: the output to use — a top-level `<output>`, a nodegraph, or
    /// `nodegraph/output` (default: the document's outputs, the first one the beauty).
    #[serde(default)]
    pub output: Option<String>,
    /// An inline network as a TOML table (the JSON format's keys).
    #[serde(default)]
    pub inline: Option<toml::Value>,
    /// An inline network as JSON text.
    #[serde(default)]
    pub json: Option<String>,
    /// Overrides `"node.input" = value`, applied to the network before linking.
    #[serde(default)]
    pub set: BTreeMap<String, toml::Value>,
    /// A displacement shader (`.osl` or `.sl`), relative to the scene file: the material
    /// (a shader source) shades with its displaced normal (bump mapping).
    #[serde(default)]
    pub displacement: Option<String>,
}

/// `[meshes.NAME]`: where a mesh's triangles come from.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum MeshSpec {
    /// The cube [−1, 1]³, faces outward.
    Box {},
    /// The unit sphere (radius 1 at the origin), tessellated.
    Sphere {
        /// Segments around the equator (rings: half as many); at least 3.
        #[serde(default = "default_segments")]
        segments: u32,
    },
    /// The square [−1, 1]² in the plane z = 0, facing +z.
    Quad {},
    /// A Wavefront OBJ file (every object in it), relative to the scene.
    Obj {
        /// The file.
        file: String,
    },
    /// A glTF 2.0 file (`.gltf` or `.glb`; every mesh of its default scene, with node
    /// transforms), relative to the scene.
    Gltf {
        /// The file.
        file: String,
    },
}

fn default_segments() -> u32 {
    48
}

/// A scale: one number (uniform) or three.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum ScaleSpec {
    /// Uniform.
    Uniform(f64),
    /// Per axis.
    Axes([f64; 3]),
}

/// `[[instances]]`: a mesh placed in the world with a material.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstanceSpec {
    /// Optional name (for messages).
    #[serde(default)]
    pub name: Option<String>,
    /// A key of `[meshes]`.
    pub mesh: String,
    /// A key of `[materials]`.
    pub material: String,
    /// Translation.
    #[serde(default)]
    pub translate: Option<[f64; 3]>,
    /// Rotation in degrees about x, then y, then z.
    #[serde(default)]
    pub rotate: Option<[f64; 3]>,
    /// Scale.
    #[serde(default)]
    pub scale: Option<ScaleSpec>,
    /// A full object → world matrix, 16 numbers row-major (points are columns); excludes
    /// translate/rotate/scale.
    #[serde(default)]
    pub matrix: Option<Vec<f64>>,
    /// Uniform string-valued geometric properties of this object (name → value), which
    /// MaterialX `geompropvalueuniform` string and filename nodes read: its material is
    /// compiled once per distinct set of the values it reads.
    #[serde(default)]
    pub geomprops: BTreeMap<String, String>,
}

/// `[[lights]]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum LightSpec {
    /// A point light; intensity in W/sr.
    Point {
        /// Position.
        position: [f64; 3],
        /// Intensity.
        #[serde(default = "unit")]
        intensity: f64,
        /// Color.
        #[serde(default = "white")]
        color: [f64; 3],
    },
    /// A spot light; intensity in W/sr.
    Spot {
        /// Position.
        position: [f64; 3],
        /// Direction it points in.
        direction: [f64; 3],
        /// Full cone angle, degrees.
        #[serde(default = "default_cone")]
        cone_angle: f64,
        /// Penumbra, degrees (Maya's sign convention).
        #[serde(default)]
        penumbra_angle: f64,
        /// cosⁿ falloff exponent.
        #[serde(default)]
        dropoff: f64,
        /// Intensity.
        #[serde(default = "unit")]
        intensity: f64,
        /// Color.
        #[serde(default = "white")]
        color: [f64; 3],
    },
    /// A distant light; intensity is the irradiance perpendicular to it.
    Distant {
        /// Direction the light travels in.
        direction: [f64; 3],
        /// Intensity.
        #[serde(default = "unit")]
        intensity: f64,
        /// Color.
        #[serde(default = "white")]
        color: [f64; 3],
    },
    /// A one-sided quad area light `corner + s·edge_u + t·edge_v`, emitting radiance towards
    /// `edge_u × edge_v`.
    Quad {
        /// Corner.
        corner: [f64; 3],
        /// First edge.
        edge_u: [f64; 3],
        /// Second edge.
        edge_v: [f64; 3],
        /// Radiance.
        #[serde(default = "unit")]
        intensity: f64,
        /// Color.
        #[serde(default = "white")]
        color: [f64; 3],
        /// Light samples per shaded point.
        #[serde(default = "four")]
        samples: u32,
        /// Whether camera and secondary rays see its face (as `emission`).
        #[serde(default = "yes")]
        visible: bool,
    },
    /// Ambient light: a radiance without direction.
    Ambient {
        /// Intensity.
        #[serde(default = "unit")]
        intensity: f64,
        /// Color.
        #[serde(default = "white")]
        color: [f64; 3],
    },
    /// An environment: radiance from every direction (constant, or a lat-long image map's),
    /// sampled in the light loop, and seen by rays that escape the scene.
    Environment {
        /// Radiance (a multiplier of the map's texels with a map).
        #[serde(default = "unit")]
        intensity: f64,
        /// Color.
        #[serde(default = "white")]
        color: [f64; 3],
        /// Light samples per shaded point.
        #[serde(default = "sixteen")]
        samples: u32,
        /// A lat-long radiance map (`.hdr` or `.exr`), relative to the scene file.
        #[serde(default)]
        map: Option<String>,
        /// The map's rotation about +y, degrees.
        #[serde(default)]
        rotation: f64,
    },
    /// A light shader (RSL `light`, `.sl`), compiled by the caller (the scene's
    /// [`Scene::shader_lights`]).
    Shader {
        /// The shader file, relative to the scene file.
        shader: String,
        /// Parameter overrides `"shader.param" = value`, as a shader material's.
        #[serde(default)]
        set: BTreeMap<String, toml::Value>,
    },
}

fn unit() -> f64 {
    1.0
}
fn white() -> [f64; 3] {
    [1.0; 3]
}
fn default_cone() -> f64 {
    40.0
}
fn yes() -> bool {
    true
}

// ---------------------------------------------------------------------------------------
// The scene, resolved
// ---------------------------------------------------------------------------------------

/// Where a material's network comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialSource {
    /// A network file (already made absolute or relative to the working directory).
    File(PathBuf),
    /// An inline network, as JSON.
    Inline(serde_json::Value),
    /// A MaterialX document and what to take from it.
    Mtlx {
        /// The document (already made absolute or relative to the working directory).
        file: PathBuf,
        /// `material = "…"`: a material of the document.
        material: Option<String>,
        /// `output = "…"`: an output of the document.
        output: Option<String>,
    },
}

/// A light shader as the scene names it (`[[lights]] type = "shader"`); the caller compiles
/// it to a light and adds it to [`Scene::lights`].
#[derive(Clone, Debug, PartialEq)]
pub struct ShaderLightRef {
    /// Its key, `lights[i]`, for messages.
    pub key: String,
    /// The shader file (already made absolute or relative to the working directory).
    pub file: PathBuf,
    /// `(shader, parameter, value)` overrides.
    pub overrides: Vec<(String, String, serde_json::Value)>,
}

/// A material as the scene names it; the caller compiles it to a program.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialRef {
    /// The key in `[materials]`.
    pub name: String,
    /// The network.
    pub source: MaterialSource,
    /// `(node, input, value)` overrides to apply to the network before linking.
    pub overrides: Vec<(String, String, serde_json::Value)>,
    /// The uniform geometric properties this compile of the material is specialized for
    /// (a MaterialX material's string-valued `geompropvalueuniform` nodes read them); empty
    /// as the scene names it.
    pub geomprops: BTreeMap<String, String>,
    /// `displacement = "…"`: a displacement shader the material shades with (already made
    /// absolute or relative to the working directory).
    pub displacement: Option<PathBuf>,
}

/// The camera, resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    /// Eye.
    pub position: DVec3,
    /// Looked-at point.
    pub look_at: DVec3,
    /// Up.
    pub up: DVec3,
    /// Vertical field of view, radians.
    pub fov: f64,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// Render settings, resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Samples per pixel (≥ 1).
    pub spp: u32,
    /// Depth limits by ray type.
    pub max_reflection_depth: u32,
    /// Refraction depth limit.
    pub max_refraction_depth: u32,
    /// Diffuse depth limit.
    pub max_diffuse_depth: u32,
    /// The passes written besides `beauty`.
    pub passes: Vec<PassDef>,
    /// Ray-match rules, first match wins.
    pub rules: Vec<Rule>,
    /// Occlusion-pass rays per point.
    pub occlusion_samples: u32,
    /// Occlusion-pass distance.
    pub occlusion_distance: f32,
    /// Tile edge.
    pub tile_size: u32,
    /// The pixel filter camera samples are drawn from.
    pub filter: PixelFilter,
    /// How closures gather area lights and the environment (materials are lowered with it;
    /// the renderer weights BSDF-sampled rays with it).
    pub light_strategy: LightStrategy,
}

/// The shape of a pixel filter (`render.filter`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterKind {
    /// Constant over the pixel (`box`): each pixel averages its own samples.
    Box,
    /// A Gaussian of standard deviation width/6, cut at ±width/2 (`gaussian`).
    Gaussian,
    /// The 4-term Blackman–Harris window over the width (`blackman-harris`).
    BlackmanHarris,
}

/// A pixel filter: its shape and full width in pixels. Camera samples are drawn with the
/// filter's density around the pixel centre (filter importance sampling), so a pixel stays
/// the plain mean of its own samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFilter {
    /// The shape.
    pub kind: FilterKind,
    /// Full width in pixels (the support is ±width/2 around the pixel centre on each axis).
    pub width: f32,
}

impl Default for PixelFilter {
    fn default() -> Self {
        PixelFilter {
            kind: FilterKind::Box,
            width: 1.0,
        }
    }
}

/// `render.filter` and `render.filter_width`, checked.
fn resolve_filter(cx: &Ctx, r: &RenderSpec) -> Result<PixelFilter, SceneError> {
    let kind = match r.filter.as_deref() {
        None | Some("box") => FilterKind::Box,
        Some("gaussian") => FilterKind::Gaussian,
        Some("blackman-harris") => FilterKind::BlackmanHarris,
        Some(other) => {
            return Err(cx.invalid(
                "render.filter",
                format!("unknown filter `{other}`: use box, gaussian or blackman-harris"),
            ));
        }
    };
    let width = match (r.filter_width, kind) {
        (Some(w), _) => {
            if !(w.is_finite() && w > 0.0 && w <= MAX_FILTER_WIDTH) {
                return Err(cx.invalid(
                    "render.filter_width",
                    format!("{w} is out of range: must be above 0 and at most {MAX_FILTER_WIDTH}"),
                ));
            }
            w as f32
        }
        (None, FilterKind::Box) => 1.0,
        (None, _) => 3.0,
    };
    Ok(PixelFilter { kind, width })
}

/// One placed mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Name for messages.
    pub name: String,
    /// Index into [`Scene::meshes`].
    pub mesh: usize,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// Object → world.
    pub transform: DMat4,
    /// Uniform string-valued geometric properties ([`InstanceSpec::geomprops`]).
    pub geomprops: BTreeMap<String, String>,
}

/// A quad light's face, for rays that see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emitter {
    /// Corner.
    pub corner: DVec3,
    /// First edge.
    pub edge_u: DVec3,
    /// Second edge.
    pub edge_v: DVec3,
    /// Radiance.
    pub radiance: [f64; 3],
    /// Its light's index in [`Scene::lights`] (for the light loop's density of it).
    pub light: usize,
}

/// A loaded scene: everything but compiled materials.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The camera.
    pub camera: CameraDesc,
    /// Render settings.
    pub settings: Settings,
    /// Materials in `[materials]` key order.
    pub materials: Vec<MaterialRef>,
    /// Meshes in `[meshes]` key order, object space.
    pub meshes: Vec<Mesh>,
    /// Their names.
    pub mesh_names: Vec<String>,
    /// Placed meshes.
    pub instances: Vec<Instance>,
    /// Lights, in runtime form.
    pub lights: Vec<LightDesc>,
    /// Quad lights whose face rays can see.
    pub emitters: Vec<Emitter>,
    /// Light shaders still to compile: the caller compiles each to a light, appends it to
    /// `lights` and empties this (the renderer refuses a scene where it is not empty).
    pub shader_lights: Vec<ShaderLightRef>,
}

/// Loads a scene file from disk, through the bounded input gate (a regular file within the
/// text limit, [`shadenet_runtime::input`]).
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let text = input::read_to_string(path, FileKind::Text, "scene")?;
    parse(&text, path)
}

/// Parses scene text; `path` names the file in messages and relative paths are resolved
/// against its directory.
pub fn parse(text: &str, path: &Path) -> Result<Scene, SceneError> {
    let file: SceneFile = toml::from_str(text).map_err(|e| SceneError::Syntax {
        path: path.to_path_buf(),
        message: e.to_string().trim_end().to_string(),
    })?;
    resolve(file, path)
}

struct Ctx<'a> {
    path: &'a Path,
    dir: PathBuf,
}

impl Ctx<'_> {
    fn invalid(&self, key: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            path: self.path.to_path_buf(),
            key: key.into(),
            message: message.into(),
        }
    }

    fn finite(&self, key: &str, v: &[f64]) -> Result<(), SceneError> {
        if let Some(x) = v.iter().find(|x| !x.is_finite()) {
            return Err(self.invalid(key, format!("{x} is not a finite number")));
        }
        Ok(())
    }

    fn vec3(&self, key: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        self.finite(key, &v)?;
        Ok(DVec3::from_array(v))
    }

    fn unit(&self, key: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        let d = self.vec3(key, v)?;
        if d.length_squared() == 0.0 {
            return Err(self.invalid(key, "the direction is zero"));
        }
        Ok(d.normalize())
    }

    /// A point of the world: finite and within the supported coordinate range.
    fn point(&self, key: &str, v: [f64; 3]) -> Result<DVec3, SceneError> {
        let p = self.vec3(key, v)?;
        if let Some(x) = v.iter().find(|x| x.abs() > MAX_COORDINATE) {
            return Err(self.invalid(key, out_of_range(*x)));
        }
        Ok(p)
    }

    /// An integer within `lo..=hi`, else an error naming the key and the range.
    fn range(&self, key: &str, v: u32, lo: u32, hi: u32) -> Result<u32, SceneError> {
        if (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(self.invalid(key, format!("{v} is out of range: must be {lo} to {hi}")))
        }
    }

    fn file(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.dir.join(p)
        }
    }
}

fn resolve(file: SceneFile, path: &Path) -> Result<Scene, SceneError> {
    let cx = Ctx {
        path,
        dir: path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from(".")),
    };
    let camera = resolve_camera(&cx, &file.camera)?;
    let materials = resolve_materials(&cx, &file.materials)?;
    let (meshes, mesh_names) = resolve_meshes(&cx, &file.meshes)?;
    let instances = resolve_instances(&cx, &file.instances, &meshes, &mesh_names, &file.materials)?;
    let Lights {
        lights,
        emitters,
        shader_lights,
    } = resolve_lights(&cx, &file.lights)?;
    let settings = resolve_settings(&cx, &file.render)?;
    Ok(Scene {
        camera,
        settings,
        materials,
        meshes,
        mesh_names,
        instances,
        lights,
        emitters,
        shader_lights,
    })
}

/// `[camera]`: a finite, non-degenerate frame, the field of view and the resolution.
fn resolve_camera(cx: &Ctx, c: &CameraSpec) -> Result<CameraDesc, SceneError> {
    let position = cx.point("camera.position", c.position)?;
    let look_at = cx.point("camera.look_at", c.look_at)?;
    let up = cx.unit("camera.up", c.up)?;
    if position == look_at {
        return Err(cx.invalid("camera.look_at", "is the camera position"));
    }
    if (look_at - position).normalize().cross(up).length_squared() < 1e-12 {
        return Err(cx.invalid("camera.up", "is parallel to the viewing direction"));
    }
    if !(c.fov.is_finite() && c.fov > 0.0 && c.fov < 180.0) {
        return Err(cx.invalid(
            "camera.fov",
            format!(
                "{} is out of range: must be between 0 and 180 degrees",
                c.fov
            ),
        ));
    }
    let [width, height] = c.resolution;
    if width == 0 || height == 0 || width > MAX_RESOLUTION || height > MAX_RESOLUTION {
        return Err(cx.invalid(
            "camera.resolution",
            format!(
                "[{width}, {height}] is out of range: must be between [1, 1] and \
                 [{MAX_RESOLUTION}, {MAX_RESOLUTION}]"
            ),
        ));
    }
    Ok(CameraDesc {
        position,
        look_at,
        up,
        fov: c.fov.to_radians(),
        width,
        height,
    })
}

/// Where one `[materials.NAME]` (`key`) comes from: exactly one of `network`, `mtlx`,
/// `inline`, `json`; `material` and `output` only with `mtlx`, and not both.
fn material_source(cx: &Ctx, key: &str, m: &MaterialSpec) -> Result<MaterialSource, SceneError> {
    if m.mtlx.is_none() {
        for (k, v) in [("material", &m.material), ("output", &m.output)] {
            if v.is_some() {
                return Err(cx.invalid(
                    format!("{key}.{k}"),
                    "only a MaterialX material (`mtlx = \"file.mtlx\"`) selects a material or output",
                ));
            }
        }
    }
    if m.material.is_some() && m.output.is_some() {
        return Err(cx.invalid(
            format!("{key}.output"),
            "give `material` or `output`, not both",
        ));
    }
    Ok(match (&m.network, &m.mtlx, &m.inline, &m.json) {
        (Some(f), None, None, None) => MaterialSource::File(cx.file(f)),
        (None, Some(f), None, None) => MaterialSource::Mtlx {
            file: cx.file(f),
            material: m.material.clone(),
            output: m.output.clone(),
        },
        (None, None, Some(t), None) => MaterialSource::Inline(
            serde_json::to_value(t)
                .map_err(|e| cx.invalid(format!("{key}.inline"), e.to_string()))?,
        ),
        (None, None, None, Some(j)) => MaterialSource::Inline(
            serde_json::from_str(j)
                .map_err(|e| cx.invalid(format!("{key}.json"), e.to_string()))?,
        ),
        _ => {
            return Err(cx.invalid(
                key,
                "give exactly one of `network` (a file), `mtlx` (a MaterialX document), `inline` (a table) or `json` (text)",
            ));
        }
    })
}

/// `[materials]`: each one's network source and its `set` overrides.
fn resolve_materials(
    cx: &Ctx,
    specs: &BTreeMap<String, MaterialSpec>,
) -> Result<Vec<MaterialRef>, SceneError> {
    let mut materials = Vec::new();
    for (name, m) in specs {
        let key = format!("materials.{name}");
        let source = material_source(cx, &key, m)?;
        let mut overrides = Vec::new();
        for (target, value) in &m.set {
            let k = format!("{key}.set.\"{target}\"");
            let Some((node, input)) = target.rsplit_once('.') else {
                return Err(cx.invalid(k, "expected \"node.input\""));
            };
            check_toml_finite(cx, &k, value)?;
            let v = serde_json::to_value(value).map_err(|e| cx.invalid(&k, e.to_string()))?;
            overrides.push((node.to_string(), input.to_string(), v));
        }
        materials.push(MaterialRef {
            name: name.clone(),
            source,
            overrides,
            geomprops: BTreeMap::new(),
            displacement: m.displacement.as_ref().map(|d| cx.file(d)),
        });
    }
    Ok(materials)
}

/// `[meshes]`: the built-in shapes and the loaded files, with their names.
fn resolve_meshes(
    cx: &Ctx,
    specs: &BTreeMap<String, MeshSpec>,
) -> Result<(Vec<Mesh>, Vec<String>), SceneError> {
    let mut meshes = Vec::new();
    let mut mesh_names = Vec::new();
    for (name, m) in specs {
        let key = format!("meshes.{name}");
        let mesh = match m {
            MeshSpec::Box {} => geometry::unit_box(),
            MeshSpec::Quad {} => geometry::unit_quad(),
            MeshSpec::Sphere { segments } => {
                cx.range(&format!("{key}.segments"), *segments, 3, MAX_SEGMENTS)?;
                geometry::unit_sphere(*segments)
            }
            MeshSpec::Obj { file: f } | MeshSpec::Gltf { file: f } => {
                let p = cx.file(f);
                let loaded = if matches!(m, MeshSpec::Obj { .. }) {
                    geometry::load_obj(&p)
                } else {
                    geometry::load_gltf(&p)
                };
                loaded.map_err(|message| SceneError::Mesh {
                    path: cx.path.to_path_buf(),
                    key: format!("{key}.file"),
                    file: p.clone(),
                    message,
                })?
            }
        };
        meshes.push(mesh);
        mesh_names.push(name.clone());
    }
    Ok((meshes, mesh_names))
}

/// `[[instances]]`: mesh and material references and the transforms.
fn resolve_instances(
    cx: &Ctx,
    specs: &[InstanceSpec],
    meshes: &[Mesh],
    mesh_names: &[String],
    materials: &BTreeMap<String, MaterialSpec>,
) -> Result<Vec<Instance>, SceneError> {
    let mat_names: Vec<&String> = materials.keys().collect();
    let mut instances = Vec::new();
    for (i, inst) in specs.iter().enumerate() {
        let key = format!("instances[{i}]");
        let mesh = mesh_names
            .iter()
            .position(|n| *n == inst.mesh)
            .ok_or_else(|| {
                cx.invalid(
                    format!("{key}.mesh"),
                    format!(
                        "no mesh `{}` in [meshes] (it has: {})",
                        inst.mesh,
                        list(mesh_names.iter())
                    ),
                )
            })?;
        let material = mat_names
            .iter()
            .position(|n| **n == inst.material)
            .ok_or_else(|| {
                cx.invalid(
                    format!("{key}.material"),
                    format!(
                        "unknown material `{}` (the scene's [materials] are: {})",
                        inst.material,
                        list(mat_names.iter().copied())
                    ),
                )
            })?;
        let transform = instance_transform(cx, &key, inst)?;
        check_extent(cx, &key, inst, &meshes[mesh], transform)?;
        instances.push(Instance {
            name: inst
                .name
                .clone()
                .unwrap_or_else(|| format!("{} #{i}", inst.mesh)),
            mesh,
            material,
            transform,
            geomprops: inst.geomprops.clone(),
        });
    }
    Ok(instances)
}

/// The scene's lights in runtime form and the faces of visible quad lights.
struct Lights {
    lights: Vec<LightDesc>,
    emitters: Vec<Emitter>,
    shader_lights: Vec<ShaderLightRef>,
}

/// `[[lights]]`.
fn resolve_lights(cx: &Ctx, specs: &[LightSpec]) -> Result<Lights, SceneError> {
    let mut lights = Vec::new();
    let mut quads = Vec::new();
    let mut shader_lights = Vec::new();
    for (i, l) in specs.iter().enumerate() {
        let key = format!("lights[{i}]");
        if let LightSpec::Shader { shader, set } = l {
            shader_lights.push(shader_light(cx, &key, shader, set)?);
            continue;
        }
        let power = |intensity: f64, color: [f64; 3]| -> Result<[f64; 3], SceneError> {
            cx.finite(&format!("{key}.intensity"), &[intensity])?;
            cx.finite(&format!("{key}.color"), &color)?;
            let p = color.map(|c| c * intensity);
            if let Some(x) = p.iter().find(|x| x.is_nan() || x.abs() > f32::MAX as f64) {
                return Err(cx.invalid(
                    format!("{key}.intensity"),
                    format!("intensity × color = {x:e} is out of range: at most ±3.4e38 (f32)"),
                ));
            }
            Ok(p)
        };
        // Positions and a quad's extent lie in the world's coordinate range.
        let point = |k: &str, v: &[f64; 3]| cx.point(&format!("{key}.{k}"), *v).map(|_| ());
        match l {
            LightSpec::Point { position, .. } | LightSpec::Spot { position, .. } => {
                point("position", position)?
            }
            LightSpec::Quad {
                corner,
                edge_u,
                edge_v,
                ..
            } => {
                point("corner", corner)?;
                point("edge_u", edge_u)?;
                point("edge_v", edge_v)?;
            }
            _ => {}
        }
        let name = format!("light{i}");
        let (kind, power) = match l {
            LightSpec::Point {
                position,
                intensity,
                color,
            } => (
                LightKind::Point {
                    position: *position,
                },
                power(*intensity, *color)?,
            ),
            LightSpec::Spot {
                position,
                direction,
                cone_angle,
                penumbra_angle,
                dropoff,
                intensity,
                color,
            } => (
                LightKind::Spot {
                    position: *position,
                    direction: *direction,
                    cone_angle: cone_angle.to_radians(),
                    penumbra_angle: penumbra_angle.to_radians(),
                    dropoff: *dropoff,
                },
                power(*intensity, *color)?,
            ),
            LightSpec::Distant {
                direction,
                intensity,
                color,
            } => (
                LightKind::Distant {
                    direction: *direction,
                },
                power(*intensity, *color)?,
            ),
            LightSpec::Quad {
                corner,
                edge_u,
                edge_v,
                intensity,
                color,
                samples,
                visible,
            } => {
                if *visible {
                    quads.push(lights.len());
                }
                (
                    LightKind::Quad {
                        corner: *corner,
                        edge_u: *edge_u,
                        edge_v: *edge_v,
                        samples: *samples,
                    },
                    power(*intensity, *color)?,
                )
            }
            LightSpec::Ambient { intensity, color } => {
                (LightKind::Ambient, power(*intensity, *color)?)
            }
            LightSpec::Shader { .. } => continue,
            LightSpec::Environment {
                intensity,
                color,
                samples,
                map,
                rotation,
            } => {
                let map = environment_map(cx, &key, map.as_deref(), *rotation)?;
                (
                    LightKind::Environment {
                        samples: *samples,
                        map,
                    },
                    power(*intensity, *color)?,
                )
            }
        };
        let light = LightDesc::new(name, kind, power).map_err(|e| {
            let field = if e.field == "power" {
                "intensity"
            } else {
                e.field
            };
            cx.invalid(format!("{key}.{field}"), e.reason)
        })?;
        lights.push(light);
    }
    Ok(Lights {
        emitters: emitters(&lights, &quads),
        lights,
        shader_lights,
    })
}

/// The faces of the visible quad lights `quads` (indices into `lights`): what camera and
/// traced rays see, with the checked corner, edges and radiance.
fn emitters(lights: &[LightDesc], quads: &[usize]) -> Vec<Emitter> {
    let mut emitters = Vec::new();
    for &i in quads {
        if let LightKind::Quad {
            corner,
            edge_u,
            edge_v,
            ..
        } = lights[i].kind
        {
            emitters.push(Emitter {
                corner: DVec3::from_array(corner),
                edge_u: DVec3::from_array(edge_u),
                edge_v: DVec3::from_array(edge_v),
                radiance: lights[i].power,
                light: i,
            });
        }
    }
    emitters
}

/// `[[lights]] type = "shader"`: the file and its `set` overrides (`"shader.param"`).
fn shader_light(
    cx: &Ctx,
    key: &str,
    shader: &str,
    set: &BTreeMap<String, toml::Value>,
) -> Result<ShaderLightRef, SceneError> {
    let mut overrides = Vec::new();
    for (target, value) in set {
        let k = format!("{key}.set.\"{target}\"");
        let Some((node, input)) = target.rsplit_once('.') else {
            return Err(cx.invalid(k, "expected \"shader.parameter\""));
        };
        check_toml_finite(cx, &k, value)?;
        let v = serde_json::to_value(value).map_err(|e| cx.invalid(&k, e.to_string()))?;
        overrides.push((node.to_string(), input.to_string(), v));
    }
    Ok(ShaderLightRef {
        key: key.to_string(),
        file: cx.file(shader),
        overrides,
    })
}

/// An environment light's `map` (read and size-checked; its texels are checked by
/// `LightDesc::new`) and `rotation`, which needs a map.
fn environment_map(
    cx: &Ctx,
    key: &str,
    map: Option<&str>,
    rotation: f64,
) -> Result<Option<std::sync::Arc<EnvImage>>, SceneError> {
    cx.finite(&format!("{key}.rotation"), &[rotation])?;
    let Some(name) = map else {
        if rotation != 0.0 {
            return Err(cx.invalid(
                format!("{key}.rotation"),
                "turns an image map: give `map` as well",
            ));
        }
        return Ok(None);
    };
    let file = cx.file(name);
    let (width, height, texels) =
        crate::envmap::load(&file).map_err(|message| SceneError::EnvMap {
            path: cx.path.to_path_buf(),
            key: format!("{key}.map"),
            file: file.clone(),
            message,
        })?;
    Ok(Some(std::sync::Arc::new(EnvImage {
        source: file.display().to_string(),
        width,
        height,
        texels,
        rotation: rotation.to_radians(),
    })))
}

fn list<'a>(names: impl Iterator<Item = &'a String>) -> String {
    let v: Vec<&str> = names.map(|s| s.as_str()).collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

fn check_toml_finite(cx: &Ctx, key: &str, v: &toml::Value) -> Result<(), SceneError> {
    match v {
        toml::Value::Float(x) if !x.is_finite() => {
            Err(cx.invalid(key, format!("{x} is not a finite number")))
        }
        toml::Value::Array(a) => a.iter().try_for_each(|x| check_toml_finite(cx, key, x)),
        toml::Value::Table(t) => t.values().try_for_each(|x| check_toml_finite(cx, key, x)),
        _ => Ok(()),
    }
}

fn instance_transform(cx: &Ctx, key: &str, inst: &InstanceSpec) -> Result<DMat4, SceneError> {
    let m = if let Some(m) = &inst.matrix {
        if inst.translate.is_some() || inst.rotate.is_some() || inst.scale.is_some() {
            return Err(cx.invalid(
                format!("{key}.matrix"),
                "give either `matrix` or `translate`/`rotate`/`scale`, not both",
            ));
        }
        if m.len() != 16 {
            return Err(cx.invalid(
                format!("{key}.matrix"),
                format!("expected 16 numbers (row-major 4×4), found {}", m.len()),
            ));
        }
        cx.finite(&format!("{key}.matrix"), m)?;
        // Row-major in the file; glam is column-major.
        DMat4::from_cols_array(&std::array::from_fn(|i| m[(i % 4) * 4 + i / 4]))
    } else {
        let t = match inst.translate {
            Some(t) => cx.vec3(&format!("{key}.translate"), t)?,
            None => DVec3::ZERO,
        };
        let r = match inst.rotate {
            Some(r) => cx.vec3(&format!("{key}.rotate"), r)?,
            None => DVec3::ZERO,
        };
        let s = match &inst.scale {
            Some(ScaleSpec::Uniform(s)) => cx.vec3(&format!("{key}.scale"), [*s; 3])?,
            Some(ScaleSpec::Axes(s)) => cx.vec3(&format!("{key}.scale"), *s)?,
            None => DVec3::ONE,
        };
        let rot = DMat4::from_rotation_z(r.z.to_radians())
            * DMat4::from_rotation_y(r.y.to_radians())
            * DMat4::from_rotation_x(r.x.to_radians());
        DMat4::from_translation(t) * rot * DMat4::from_scale(s)
    };
    let det = m.determinant();
    let inv = m.inverse();
    if det.abs() < 1e-300 || !det.is_finite() || !inv.is_finite() {
        let (k, why) = if inst.matrix.is_some() {
            (
                format!("{key}.matrix"),
                "the matrix is singular (not invertible)",
            )
        } else {
            (
                format!("{key}.scale"),
                "the transform is singular (a zero scale flattens the mesh)",
            )
        };
        return Err(cx.invalid(k, why));
    }
    Ok(m)
}

/// Checks that every vertex of an instance's mesh stays within [`MAX_COORDINATE`] after
/// its transform, naming the key that takes it out: `translate` when the translation
/// alone is out of range, `scale` when the scaled mesh is, `matrix`, or the instance when
/// only the composition is.
fn check_extent(
    cx: &Ctx,
    key: &str,
    inst: &InstanceSpec,
    mesh: &Mesh,
    m: DMat4,
) -> Result<(), SceneError> {
    let reach = |m: DMat4| {
        mesh.positions
            .iter()
            .map(|p| m.transform_point3(DVec3::from(p.map(f64::from))))
            .map(|q| q.abs().max_element())
            .fold(0.0f64, |a, b| if b.is_nan() || b > a { b } else { a })
    };
    let fits = |x: f64| x <= MAX_COORDINATE;
    if let Some(t) = inst.translate {
        cx.point(&format!("{key}.translate"), t)?;
    }
    if let Some(s) = &inst.scale {
        let s = match s {
            ScaleSpec::Uniform(s) => DVec3::splat(*s),
            ScaleSpec::Axes(s) => DVec3::from_array(*s),
        };
        let r = reach(DMat4::from_scale(s));
        if !fits(r) {
            return Err(cx.invalid(
                format!("{key}.scale"),
                format!("the scaled mesh reaches {r:e}, {}", beyond_range()),
            ));
        }
    }
    let r = reach(m);
    if !fits(r) {
        let k = if inst.matrix.is_some() {
            format!("{key}.matrix")
        } else {
            key.to_string()
        };
        return Err(cx.invalid(
            k,
            format!("the transformed mesh reaches {r:e}, {}", beyond_range()),
        ));
    }
    Ok(())
}

fn resolve_settings(cx: &Ctx, r: &RenderSpec) -> Result<Settings, SceneError> {
    cx.range("render.spp", r.spp, 1, MAX_SPP)?;
    cx.range(
        "render.max_reflection_depth",
        r.max_reflection_depth,
        0,
        MAX_DEPTH,
    )?;
    cx.range(
        "render.max_refraction_depth",
        r.max_refraction_depth,
        0,
        MAX_DEPTH,
    )?;
    cx.range(
        "render.max_diffuse_depth",
        r.max_diffuse_depth,
        0,
        MAX_DEPTH,
    )?;
    cx.range("render.tile_size", r.tile_size, 1, MAX_TILE_SIZE)?;
    cx.range(
        "render.occlusion_samples",
        r.occlusion_samples,
        1,
        MAX_OCCLUSION_SAMPLES,
    )?;
    let d = r.occlusion_distance;
    if !(d.is_finite() && d > 0.0 && d <= f32::MAX as f64) {
        return Err(cx.invalid(
            "render.occlusion_distance",
            format!("{d} is out of range: must be a positive number at most 3.4e38"),
        ));
    }
    let mut passes: Vec<PassDef> = Vec::new();
    for (i, name) in r.passes.iter().enumerate() {
        let p =
            PassDef::standard(name).map_err(|e| cx.invalid(format!("render.passes[{i}]"), e))?;
        passes.push(p);
    }
    for (i, p) in r.pass.iter().enumerate() {
        let key = format!("render.pass[{i}]");
        let kind = match (&p.components, &p.override_) {
            (Some(c), None) if !c.is_empty() => PassKind::Components(c.clone()),
            (None, Some(o)) => PassKind::Override(
                o.parse()
                    .map_err(|e: String| cx.invalid(format!("{key}.override"), e))?,
            ),
            _ => {
                return Err(cx.invalid(
                    key,
                    "give either `components` (a non-empty list) or `override`",
                ));
            }
        };
        passes.push(PassDef {
            name: p.name.clone(),
            kind,
        });
    }
    crate::passes::check_pass_names(&passes).map_err(|e| cx.invalid("render.passes", e))?;
    let mut rules = Vec::new();
    for (i, s) in r.rules.iter().enumerate() {
        let key = format!("render.rules[{i}]");
        let ray = match s.ray.as_deref() {
            None | Some("any") => None,
            Some(t) => Some(RayMatch::parse(t).map_err(|e| cx.invalid(format!("{key}.ray"), e))?),
        };
        for (k, v) in [
            ("depth", s.depth),
            ("min_depth", s.min_depth),
            ("max_depth", s.max_depth),
        ] {
            if let Some(v) = v {
                cx.range(&format!("{key}.{k}"), v, 0, MAX_DEPTH)?;
            }
        }
        let (min_depth, max_depth) = match (s.depth, s.min_depth, s.max_depth) {
            (Some(d), None, None) => (d, d),
            (None, lo, hi) => (lo.unwrap_or(0), hi.unwrap_or(u32::MAX)),
            _ => {
                return Err(cx.invalid(
                    format!("{key}.depth"),
                    "give `depth` or `min_depth`/`max_depth`, not both",
                ));
            }
        };
        let action = match (&s.components, &s.override_) {
            (Some(c), None) if c.iter().any(|x| x == "all") => RuleAction::All,
            (Some(c), None) => RuleAction::Components(c.clone()),
            (None, Some(o)) => RuleAction::Override(
                o.parse()
                    .map_err(|e: String| cx.invalid(format!("{key}.override"), e))?,
            ),
            _ => {
                return Err(cx.invalid(
                    key,
                    "give either `components` (a list, or [\"all\"]) or `override`",
                ));
            }
        };
        rules.push(Rule {
            ray,
            min_depth,
            max_depth,
            action,
        });
    }
    Ok(Settings {
        spp: r.spp,
        max_reflection_depth: r.max_reflection_depth,
        max_refraction_depth: r.max_refraction_depth,
        max_diffuse_depth: r.max_diffuse_depth,
        passes,
        rules,
        occlusion_samples: r.occlusion_samples,
        occlusion_distance: r.occlusion_distance as f32,
        tile_size: r.tile_size,
        filter: resolve_filter(cx, r)?,
        light_strategy: match &r.light_strategy {
            None => LightStrategy::Mis,
            Some(n) => n
                .parse()
                .map_err(|e: String| cx.invalid("render.light_strategy", e))?,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\n\
        [materials.m]\njson = '{\"nodes\": [], \"outputs\": {}}'\n[meshes.q]\ntype = \"quad\"\n";

    fn err(extra: &str) -> String {
        parse(&format!("{HEAD}{extra}"), Path::new("s.toml"))
            .err()
            .unwrap_or_else(|| panic!("accepted: {extra}"))
            .to_string()
    }

    /// `[[lights]] type = "shader"`: kept for the caller to compile, after the built-in
    /// lights, with its file relative to the scene and its overrides split at the last dot.
    #[test]
    fn light_shaders_are_kept_for_the_caller() {
        let text = format!(
            "{HEAD}[[lights]]\ntype = \"shader\"\nshader = \"../l/spot.sl\"\nset = {{ \"spot.from\" = [0, 1, 2] }}\n\
             [[lights]]\ntype = \"point\"\nposition = [0, 0, 1]\n"
        );
        let s = parse(&text, Path::new("dir/s.toml")).unwrap();
        assert_eq!(s.lights.len(), 1);
        assert_eq!(s.shader_lights.len(), 1);
        let l = &s.shader_lights[0];
        assert_eq!(l.key, "lights[0]");
        assert_eq!(l.file, Path::new("dir/../l/spot.sl"));
        assert_eq!(
            l.overrides,
            vec![(
                "spot".to_string(),
                "from".to_string(),
                serde_json::json!([0, 1, 2])
            )]
        );
    }

    #[test]
    fn errors_name_the_key() {
        let inst = "[[instances]]\nmesh = \"q\"\nmaterial = \"m\"\n";
        for (extra, want) in [
            (format!("{inst}matrix = [1, 0, 0]\n"), "instances[0].matrix"),
            (format!("{inst}scale = [1, 0, 1]\n"), "singular"),
            (format!("{inst}rotate = [0, inf, 0]\n"), "instances[0].rotate"),
            (format!("{inst}translate = [0, 0, 0]\nmatrix = [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n"), "not both"),
            ("[render]\nspp = 0\n".to_string(), "render.spp"),
            ("[render]\npasses = [\"beauty\"]\n".to_string(), "always written"),
            ("[render]\npasses = [\"diffuse\", \"diffuse\"]\n".to_string(), "twice"),
            ("[[render.rules]]\nray = \"glossy\"\ncomponents = [\"diffuse\"]\n".to_string(), "render.rules[0].ray"),
            ("[[render.pass]]\nname = \"x\"\noverride = \"curvature\"\n".to_string(), "render.pass[0].override"),
            ("[[lights]]\ntype = \"quad\"\ncorner = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [2, 0, 0]\n".to_string(), "no area"),
            ("[[lights]]\ntype = \"laser\"\n".to_string(), "laser"),
            // The rules every source of lights shares (LightDesc::new), named by the key.
            ("[[lights]]\ntype = \"spot\"\nposition = [0, 0, 1]\ndirection = [0, 0, -1]\ncone_angle = 400\n".to_string(), "lights[0].cone_angle"),
            ("[[lights]]\ntype = \"spot\"\nposition = [0, 0, 1]\ndirection = [0, 0, -1]\ndropoff = -1\n".to_string(), "lights[0].dropoff"),
            ("[[lights]]\ntype = \"distant\"\ndirection = [0, 0, 0]\n".to_string(), "lights[0].direction"),
            ("[[lights]]\ntype = \"environment\"\nsamples = 0\n".to_string(), "lights[0].samples"),
            ("[[lights]]\ntype = \"point\"\nposition = [0, nan, 1]\n".to_string(), "lights[0].position"),
            ("[[lights]]\ntype = \"point\"\nposition = [0, 0, 1]\nintensty = 3\n".to_string(), "intensty"),
            ("[meshes.s]\ntype = \"sphere\"\nsegments = 2\n".to_string(), "meshes.s.segments"),
            ("[materials.n]\nnetwork = \"a.json\"\njson = '{}'\n".to_string(), "exactly one"),
            ("[materials.n]\nnetwork = \"a.json\"\nset = { \"color\" = 1 }\n".to_string(), "node.input"),
            // Light shaders: the file is required, `set` keys are "shader.parameter" with
            // finite values, the built-in lights' keys do not apply.
            ("[[lights]]\ntype = \"shader\"\n".to_string(), "shader"),
            ("[[lights]]\ntype = \"shader\"\nshader = \"l.sl\"\nset = { \"intensity\" = 1 }\n".to_string(), "`lights[0].set.\"intensity\"`: expected \"shader.parameter\""),
            ("[[lights]]\ntype = \"shader\"\nshader = \"l.sl\"\nset = { \"l.intensity\" = nan }\n".to_string(), "lights[0].set.\"l.intensity\""),
            ("[[lights]]\ntype = \"shader\"\nshader = \"l.sl\"\nintensity = 2\n".to_string(), "intensity"),
        ] {
            let e = err(&extra);
            assert!(e.contains(want), "{extra}: `{want}` not in {e}");
            assert!(e.starts_with("s.toml"), "{e}");
        }
    }

    /// Hostile values (issue 24): each is an error naming its key (before, most of them
    /// loaded and then panicked inside obvhs or rendered from infinite values).
    #[test]
    fn hostile_values_name_their_key() {
        let ok = "[[instances]]\nmesh = \"q\"\nmaterial = \"m\"\n";
        let inst = format!("{ok}{ok}");
        for (extra, key, want) in [
            (format!("{inst}scale = 1e20\n"), "instances[1].scale", "outside the supported coordinate range ±1e13"),
            (format!("{inst}scale = [1, 1e20, 1]\n"), "instances[1].scale", "1e20"),
            (format!("{inst}translate = [0, 1e39, 0]\n"), "instances[1].translate", "1e39 is outside"),
            (format!("{inst}matrix = [1,0,0,0, 0,nan,0,0, 0,0,1,0, 0,0,0,1]\n"), "instances[1].matrix", "NaN is not a finite number"),
            (format!("{inst}matrix = [1,0,0,inf, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n"), "instances[1].matrix", "inf is not a finite number"),
            (format!("{inst}matrix = [1,0,0,0, 0,1,0,0, 0,0,0,0, 0,0,0,1]\n"), "instances[1].matrix", "singular"),
            (format!("{inst}matrix = [1e20,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\n"), "instances[1].matrix", "reaches 1e20"),
            (format!("{inst}rotate = [0, 0, 45]\nscale = 9e12\n"), "instances[1]`", "reaches 1.2727"),
            ("[render]\nspp = 65537\n".into(), "render.spp", "65537 is out of range: must be 1 to 65536"),
            ("[render]\nmax_diffuse_depth = 65\n".into(), "render.max_diffuse_depth", "0 to 64"),
            ("[render]\nmax_reflection_depth = 4294967295\n".into(), "render.max_reflection_depth", "0 to 64"),
            ("[render]\ntile_size = 1025\n".into(), "render.tile_size", "1 to 1024"),
            ("[render]\nocclusion_samples = 65537\n".into(), "render.occlusion_samples", "1 to 65536"),
            ("[render]\nocclusion_distance = 1e39\n".into(), "render.occlusion_distance", "out of range"),
            ("[render]\nfilter_width = 0\n".into(), "render.filter_width", "out of range"),
            ("[render]\nfilter = \"tent\"\n".into(), "render.filter", "unknown filter `tent`"),
            ("[render]\nlight_strategy = \"nee\"\n".into(), "render.light_strategy", "unknown light strategy `nee` (known: mis, light, bsdf)"),
            ("[[render.rules]]\nray = \"camera\"\ndepth = 65\ncomponents = [\"all\"]\n".into(), "render.rules[0].depth", "0 to 64"),
            ("[meshes.s]\ntype = \"sphere\"\nsegments = 4097\n".into(), "meshes.s.segments", "3 to 4096"),
            ("[[lights]]\ntype = \"point\"\nposition = [0, 1e30, 0]\n".into(), "lights[0].position", "1e30 is outside"),
            ("[[lights]]\ntype = \"quad\"\ncorner = [0, 0, 0]\nedge_u = [1e14, 0, 0]\nedge_v = [0, 1, 0]\n".into(), "lights[0].edge_u", "outside"),
            ("[[lights]]\ntype = \"point\"\nposition = [0, 0, 1]\nintensity = 1e300\ncolor = [1e10, 1, 1]\n".into(), "lights[0].intensity", "out of range"),
        ] {
            let e = err(&extra);
            assert!(e.contains(key) && e.contains(want), "{extra}: `{key}` … `{want}` not in {e}");
        }
        // The camera: the HEAD's camera table, moved.
        for (cam, key) in [
            (
                "position = [0, 0, 1e30]\nlook_at = [0, 0, 0]",
                "camera.position",
            ),
            (
                "position = [0, 0, 3]\nlook_at = [0, -1e14, 0]",
                "camera.look_at",
            ),
            (
                "position = [0, 0, 3]\nlook_at = [0, 0, 0]\nresolution = [16385, 1]",
                "camera.resolution",
            ),
            (
                "position = [0, 0, 3]\nlook_at = [0, 0, 0]\nresolution = [0, 1]",
                "camera.resolution",
            ),
        ] {
            let text = HEAD.replace("position = [0, 0, 3]\nlook_at = [0, 0, 0]", cam);
            let e = parse(&text, Path::new("s.toml")).unwrap_err().to_string();
            assert!(e.contains(key) && e.contains("range"), "{cam}: {e}");
        }
    }

    /// At the edge of the range: accepted.
    #[test]
    fn the_largest_coordinates_are_accepted() {
        let text = format!(
            "{HEAD}[[instances]]\nmesh = \"q\"\nmaterial = \"m\"\nscale = {MAX_COORDINATE:e}\n\
             [[instances]]\nmesh = \"q\"\nmaterial = \"m\"\ntranslate = [0, 0, {MAX_COORDINATE:e}]\n"
        )
        .replace("position = [0, 0, 3]", &format!("position = [0, 0, {MAX_COORDINATE:e}]"));
        parse(&text, Path::new("s.toml")).unwrap_or_else(|e| panic!("{e}"));
        // One step beyond, rejected.
        let beyond = text.replace(
            &format!("scale = {MAX_COORDINATE:e}"),
            &format!("scale = {:e}", MAX_COORDINATE * 1.000001),
        );
        let e = parse(&beyond, Path::new("s.toml")).unwrap_err().to_string();
        assert!(e.contains("instances[0].scale"), "{e}");
    }

    /// Files go through the input gate: a device and an oversized file are errors naming
    /// the file and the key.
    #[cfg(unix)]
    #[test]
    fn devices_and_oversized_files_are_refused() {
        let e = load(Path::new("/dev/zero")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "/dev/zero: not a regular file (a character device); text input must be a regular file"
        );
        for ty in ["obj", "gltf"] {
            let e = err(&format!(
                "[meshes.z]\ntype = \"{ty}\"\nfile = \"/dev/zero\"\n"
            ));
            assert!(
                e.contains("meshes.z.file")
                    && e.contains("not a regular file (a character device)"),
                "{e}"
            );
        }
        let dir = std::env::temp_dir().join(format!("shadenet-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let big = dir.join("big.obj");
        let f = std::fs::File::create(&big).unwrap();
        f.set_len(FileKind::Mesh.default_limit() + 1).unwrap();
        let e = err(&format!(
            "[meshes.z]\ntype = \"obj\"\nfile = \"{}\"\n",
            big.display()
        ));
        assert!(
            e.contains("meshes.z.file") && e.contains("over the 2147483648-byte limit"),
            "{e}"
        );
        // A mesh whose own coordinates are out of range names the mesh.
        let far = dir.join("far.obj");
        std::fs::write(&far, "v 0 0 0\nv 1e20 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let e = err(&format!(
            "[meshes.z]\ntype = \"obj\"\nfile = \"{}\"\n",
            far.display()
        ));
        assert!(
            e.contains("meshes.z.file") && e.contains("outside the supported range"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Each level says its own part once (the cause used to be printed twice).
    #[test]
    fn a_missing_scene_says_why_once() {
        let e = load(Path::new("nonexist.toml")).unwrap_err();
        assert_eq!(
            shadenet_graph::error_chain(&e),
            "cannot read scene nonexist.toml: No such file or directory (os error 2)"
        );
    }

    #[test]
    fn transforms_compose_translate_rotate_scale() {
        let s = parse(
            &format!(
                "{HEAD}[[instances]]\nmesh = \"q\"\nmaterial = \"m\"\n\
                 translate = [1, 2, 3]\nrotate = [0, 90, 0]\nscale = 2\n\
                 [[instances]]\nmesh = \"q\"\nmaterial = \"m\"\n\
                 matrix = [1, 0, 0, 5,  0, 1, 0, 6,  0, 0, 1, 7,  0, 0, 0, 1]\n"
            ),
            Path::new("s.toml"),
        )
        .unwrap();
        let p = s.instances[0]
            .transform
            .transform_point3(DVec3::new(1.0, 0.0, 0.0));
        // scale 2 → (2,0,0); rotate 90° about y → (0,0,-2); translate → (1,2,1).
        assert!((p - DVec3::new(1.0, 2.0, 1.0)).length() < 1e-12, "{p}");
        let q = s.instances[1].transform.transform_point3(DVec3::ZERO);
        assert_eq!(q, DVec3::new(5.0, 6.0, 7.0), "row-major, points as columns");
    }
}
