//! Set-up: the [`Renderer`] a scene becomes (BVH built, components found, ray-match actions
//! tabled, every specialized shader compiled), its errors and its shading mode. It owns the
//! renderer's state; it must not trace or shade (the stages do, through `impl Renderer`
//! blocks in their own files).

use super::error::RenderError;

use super::compile::{
    Action, Specialized, action_table, compile_materials, compile_overrides, scene_components,
    shade_envs,
};
use super::pixel::PixelSampler;
use super::stats::RenderStats;
use crate::accel::Accel;
use crate::camera::Camera;
use crate::passes::{Components, OverrideKind};
use crate::scene::Scene;
use crate::shader::ShaderBackend;
use shadenet_graph::ir::Program;
use shadenet_runtime::{Light, ShadeEnv};
use std::time::Instant;

/// How camera hits are shaded (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadingMode {
    /// Each hit as it is found, one [`Shader::shade`] call each.
    Immediate,
    /// Traced in groups of tiles first, then shaded per shader in batches.
    Deferred(DeferredOptions),
}

/// Options of the deferred mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeferredOptions {
    /// Camera samples traced before shading: consecutive tiles (row by row) are grouped
    /// until they hold at least this many (at least one tile per group). A group's hits
    /// are then split per material and environment, so a group should be several times
    /// the smallest batch worth a GPU dispatch (about 16K fragments: below that the fixed
    /// cost of an upload, a submission and a readback dominates and a large GPU is not
    /// filled). Default [`DeferredOptions::DEFAULT_GROUP_SAMPLES`].
    pub group_samples: usize,
}

impl DeferredOptions {
    /// 65 536 samples: a group of tiles covering a quarter of a 256×256 frame at 4 spp, or
    /// a 640×360 frame in 15 groups, which keeps both threads of a two-core machine busy
    /// (groups trace and shade in parallel) while a material covering a quarter of the
    /// frame still gets batches of 16K fragments. Memory: about 4 KB per sample and group
    /// in flight (samples, fragments, hits).
    pub const DEFAULT_GROUP_SAMPLES: usize = 1 << 16;
}

impl Default for DeferredOptions {
    fn default() -> Self {
        DeferredOptions {
            group_samples: DeferredOptions::DEFAULT_GROUP_SAMPLES,
        }
    }
}

/// A scene ready to render: BVH built, materials specialized and compiled.
pub struct Renderer {
    pub(super) scene: Scene,
    pub(super) camera: Camera,
    /// Where camera samples sit: the pixel filter over the sampler's points.
    pub(super) sampler: PixelSampler,
    pub(super) accel: Accel,
    pub(super) components: Components,
    /// Per instance: lights, camera and object transforms.
    pub(super) envs: Vec<ShadeEnv>,
    /// `shaders[material][action]`.
    pub(super) shaders: Vec<Vec<Specialized>>,
    pub(super) overrides: Vec<(OverrideKind, Specialized)>,
    /// `table[ray type][depth]` (depth clamped to the last entry).
    pub(super) table: Vec<Vec<Action>>,
    /// Whether any shader reads ray differentials (then camera rays carry them).
    pub(super) differentials: bool,
    pub(super) emission: usize,
    pub(super) warnings: Vec<String>,
    pub(super) stats: RenderStats,
    pub(super) mode: ShadingMode,
    /// The scene's lights, prepared once (environment maps' distributions built): what
    /// escaped rays see and the densities that weight BSDF rays reaching a light.
    pub(super) lights: Vec<Light>,
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Renderer")
            .field("accel", &self.accel)
            .field("components", &self.components)
            .finish()
    }
}

impl Renderer {
    /// Prepares a scene whose materials (in `scene.materials` order) are compiled to
    /// `programs`: builds the BVH, specializes each material per distinct component mask
    /// the ray-match rules produce (and the override shaders), and compiles them with
    /// `backend`. Camera hits are shaded deferred, in batches, when the back end prefers
    /// batches, else immediately ([`Renderer::set_shading_mode`] changes it).
    pub fn new(
        scene: Scene,
        programs: Vec<Program>,
        backend: &dyn ShaderBackend,
    ) -> Result<Renderer, RenderError> {
        if programs.len() != scene.materials.len() {
            return Err(RenderError::MaterialCount {
                scene: scene.materials.len(),
                given: programs.len(),
            });
        }
        if let Some(l) = scene.shader_lights.first() {
            return Err(RenderError::ShaderLight {
                light: l.key.clone(),
                file: l.file.clone(),
            });
        }
        let mut stats = RenderStats::default();
        let t = Instant::now();
        let accel = Accel::build(&scene.meshes, &scene.instances);
        if let Some((i, triangles)) = accel.rejected() {
            return Err(RenderError::Geometry {
                instance: scene.instances[i as usize].name.clone(),
                triangles,
            });
        }
        stats.bvh_time = t.elapsed();
        stats.triangles = accel.triangle_count();

        let t = Instant::now();
        let (components, emission, mut warnings) = scene_components(&scene, &programs)?;
        let s = &scene.settings;
        let (actions, table) = action_table(s);
        let mut differentials = false;
        let (shaders, attribute_warnings) = compile_materials(
            &scene,
            &programs,
            &actions,
            backend,
            &components,
            &mut stats,
            &mut differentials,
        )?;
        warnings.extend(attribute_warnings);
        let overrides = compile_overrides(
            s,
            &table,
            backend,
            &components,
            &mut stats,
            &mut differentials,
        )?;
        stats.compile_time = t.elapsed();

        let camera = Camera::new(&scene.camera);
        let sampler = PixelSampler::new(scene.settings.filter);
        let lights: Vec<Light> = scene.lights.iter().map(Light::from_desc).collect();
        let envs = shade_envs(&scene, &lights);
        Ok(Renderer {
            lights,
            scene,
            camera,
            sampler,
            accel,
            components,
            envs,
            shaders,
            overrides,
            table,
            differentials,
            emission,
            warnings,
            stats,
            mode: if backend.prefers_batches() {
                ShadingMode::Deferred(DeferredOptions::default())
            } else {
                ShadingMode::Immediate
            },
        })
    }

    /// Sets the samples per pixel of the next renders (clamped to 1 to
    /// [`crate::scene::MAX_SPP`]): the same renderer renders at several sample counts
    /// without compiling again.
    pub fn set_spp(&mut self, spp: u32) {
        self.scene.settings.spp = spp.clamp(1, crate::scene::MAX_SPP);
    }

    /// How camera hits are shaded.
    pub fn shading_mode(&self) -> ShadingMode {
        self.mode
    }

    /// Shades camera hits immediately or deferred in batches (both give the same image with
    /// a CPU back end). A group size of 0 is taken as 1.
    pub fn set_shading_mode(&mut self, mode: ShadingMode) {
        self.mode = match mode {
            ShadingMode::Deferred(o) => ShadingMode::Deferred(DeferredOptions {
                group_samples: o.group_samples.max(1),
            }),
            m => m,
        };
    }

    /// Problems worth telling the user that do not stop the render (a pass naming a
    /// component no material has).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The scene's render components (the film's component layers), in order.
    pub fn components(&self) -> &[String] {
        &self.components.names
    }
}
