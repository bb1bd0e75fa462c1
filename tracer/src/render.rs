//! The integrator: camera rays, shading hits through specialized materials, the scene
//! services shaders call back into, and the tiles on rayon.
//!
//! # What a hit gets
//!
//! The fragment holds, in world space: `P` (from barycentrics), `N` (interpolated vertex
//! normal, flipped to the side of the geometric normal that faces the incoming ray), `Ng`
//! (the triangle's geometric normal **as wound**, counter-clockwise front — not flipped, so
//! a shader can tell entering from leaving a closed mesh by the sign of `I·Ng`), `I = P −
//! ray origin`, and, only when the specialized program's needs ask for them: `uv`, `dPdu`,
//! `dPdv` (from the triangle's uv parameterization) and `dPdx`, `dPdy` (ray differentials:
//! Igehy 1999, camera differentials transferred to the hit's tangent plane and carried
//! through reflection and refraction rays; diffuse rays drop them).
//!
//! # Determinism
//!
//! Pixel sample `k` of pixel `(x, y)` sits at a rotated R2 low-discrepancy point (pixel
//! centres when `spp = 1`) and gets `Fragment::seed = hash(x, y, k)`; secondary rays hash
//! the parent's seed with the ray type, depth and direction. Nothing depends on which thread
//! renders a tile, so images are bit-identical for any thread count.
//!
//! # Immediate and deferred shading
//!
//! In the **immediate** mode (the CPU back ends' default) each camera hit is shaded as soon
//! as it is found, one [`Shader::shade`] call per hit. In the **deferred** mode (chosen when
//! the back end [prefers batches](crate::shader::ShaderBackend::prefers_batches), the GPU,
//! or set with [`Renderer::set_shading_mode`]) a group of tiles of at least
//! [`DeferredOptions::group_samples`] camera samples is traced first; the shading calls its
//! hits need (the material's, the override rule's, each override pass's) are collected per
//! shader and environment and each such group is shaded with one [`Shader::shade_many`]
//! call; then every sample is finished exactly as the immediate path finishes it (same
//! film layout, same order of additions, same seeds and statistics), so for a CPU back end
//! the two modes give the same bits. Secondary hits shaded from inside a `trace` stay
//! immediate in both modes.
//!
//! The tracer's scene services carry per-hit state (the hit point the robust ray offset
//! starts from, the facing normals, the seed secondary rays hash, the ray differentials
//! they carry). A batch gets `BatchServices`: fragment `i`'s own services through
//! `SceneServices::fragment(i)`, which every back end's `shade_many` asks for (a ray that
//! belongs to no fragment starts detached, where asked).

use crate::accel::{Accel, Hit, orthonormal};
use crate::camera::Camera;
/// The ray differentials live with the camera that starts them; re-exported here, where
/// secondary rays carry them on.
pub use crate::camera::RayDiffs;
use crate::film::{Film, Layer};
use crate::passes::{
    Components, KNOWN_COMPONENTS, OverrideKind, PassKind, RayMatch, RuleAction, action_for,
    program_mask,
};
use crate::scene::{Emitter, Scene, Settings};
use crate::shader::{Shader, ShaderBackend};
use glam::{DMat4, Vec3};
use rayon::prelude::*;
use shadenet_graph::ir::Program;
use shadenet_graph::ir::{Space, Stream};
use shadenet_graph::ops::math;
use shadenet_graph::opt::{self, Needs, Specialization};
use shadenet_runtime::{
    BatchTimes, Fragment, SceneServices, ShadeCtx, ShadeEnv, ShadeOut, Transform,
};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Why a scene cannot be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene and the compiled materials do not match.
    #[error("the scene has {scene} materials but {given} programs were given")]
    MaterialCount {
        /// Materials in the scene.
        scene: usize,
        /// Programs given.
        given: usize,
    },
    /// A material could not be compiled by the back end.
    #[error("material `{material}`: {message}")]
    Compile {
        /// The material (or override) name.
        material: String,
        /// Why.
        message: String,
    },
    /// A pass or rule names an unknown component.
    #[error("{0}")]
    Pass(String),
    /// An instance's transformed vertices are not finite or lie beyond the supported
    /// coordinate range (a scene built by hand; a loaded scene is checked with its keys).
    #[error(
        "instance `{instance}`: {triangles} triangle(s) have a vertex that is not finite or \
         lies outside the supported coordinate range ±{:e}",
        crate::geometry::MAX_COORDINATE
    )]
    Geometry {
        /// The first instance concerned.
        instance: String,
        /// Triangles left out, over all instances.
        triangles: usize,
    },
}

/// What the render did, for the end summary.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Building the BVH.
    pub bvh_time: Duration,
    /// Specializing and compiling materials.
    pub compile_time: Duration,
    /// Rendering the tiles.
    pub render_time: Duration,
    /// Triangles in the BVH.
    pub triangles: usize,
    /// Distinct specialized shaders compiled (materials × masks, and overrides).
    pub shaders: usize,
    /// Rays traced: camera, secondary, shadow and occlusion.
    pub rays: u64,
    /// Shading calls (materials and overrides).
    pub shading_calls: u64,
    /// Non-finite values the output guard replaced with 0.
    pub nonfinite: u64,
    /// Deferred mode: [`Shader::shade_many`] calls made (0 in the immediate mode).
    pub batches: u64,
    /// Deferred mode: fragments shaded through those calls (camera hits; every shading call
    /// of a camera hit, overrides included).
    pub batched_fragments: u64,
    /// Deferred mode: the largest batch, in fragments.
    pub largest_batch: u64,
    /// Deferred mode: where the batch calls' time went, summed over all calls (and threads:
    /// groups of tiles shade in parallel). A CPU back end reports only `kernels`.
    pub batch_times: BatchTimes,
}

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

/// One specialized program, compiled.
#[derive(Clone)]
struct Specialized {
    shader: Arc<dyn Shader>,
    /// The component mask it was specialized for (also given to the shading context).
    mask: u32,
    /// Compute uv and tangents.
    uv_tangents: bool,
    /// Compute ray differentials.
    differentials: bool,
    /// Reads object space (then its environment's object transform matters, and hits of
    /// different instances cannot share a batch).
    object_space: bool,
    /// The output parts the film reads.
    parts: Vec<Part>,
}

impl Specialized {
    fn new(
        program: &Program,
        mask: u32,
        needs: &Needs,
        backend: &dyn ShaderBackend,
        components: &Components,
        name: &str,
    ) -> Result<Specialized, RenderError> {
        let shader = backend
            .compile(program)
            .map_err(|message| RenderError::Compile {
                material: name.to_string(),
                message,
            })?;
        // The first output is the beauty: every part of it (tagged or not). A component
        // the first output lacks may come from another output (a surface's `outShadow`):
        // its first such part feeds that component's pass but not the beauty.
        let first = program.outputs.first().map(|o| o.name.clone());
        let mut parts: Vec<Part> = Vec::new();
        let mut offset = 0;
        let mut slots = Vec::new();
        for o in &program.outputs {
            let w = program.ty(o.value).width().max(1);
            let comp = o
                .component
                .and_then(|k| program.components.get(k as usize))
                .and_then(|n| components.index(n));
            slots.push((Some(&o.name) == first.as_ref(), comp, offset, w));
            offset += w;
        }
        for &(is_first, comp, offset, width) in &slots {
            if is_first {
                parts.push(Part {
                    comp,
                    offset,
                    width,
                    beauty: true,
                });
            }
        }
        for &(is_first, comp, offset, width) in &slots {
            if let (false, Some(k)) = (is_first, comp)
                && !parts.iter().any(|p| p.comp == Some(k))
            {
                parts.push(Part {
                    comp,
                    offset,
                    width,
                    beauty: false,
                });
            }
        }
        Ok(Specialized {
            shader,
            mask,
            uv_tangents: needs.streams.contains(&Stream::Uv) || needs.tangents(),
            differentials: needs.differentials(),
            object_space: needs.spaces.contains(&Space::Object),
            parts,
        })
    }
}

/// One output part the film reads.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Part {
    /// Scene component index, or `None` for an untagged (beauty-only) value.
    comp: Option<usize>,
    /// First float in the shading call's output.
    offset: usize,
    /// Floats.
    width: usize,
    /// Whether it is part of the beauty (the first output).
    beauty: bool,
}

/// What hits compute, per ray type and depth.
#[derive(Clone, Debug, PartialEq)]
enum Action {
    /// Shade the material specialized to action number `usize`.
    Material(usize),
    /// An override shader.
    Override(OverrideKind),
}

/// A scene ready to render: BVH built, materials specialized and compiled.
pub struct Renderer {
    scene: Scene,
    camera: Camera,
    accel: Accel,
    components: Components,
    /// Per instance: lights, camera and object transforms.
    envs: Vec<ShadeEnv>,
    /// `shaders[material][action]`.
    shaders: Vec<Vec<Specialized>>,
    overrides: Vec<(OverrideKind, Specialized)>,
    /// `table[ray type][depth]` (depth clamped to the last entry).
    table: Vec<Vec<Action>>,
    /// Whether any shader reads ray differentials (then camera rays carry them).
    differentials: bool,
    emission: usize,
    warnings: Vec<String>,
    stats: RenderStats,
    mode: ShadingMode,
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Renderer")
            .field("accel", &self.accel)
            .field("components", &self.components)
            .finish()
    }
}

/// The scene's render components: those the programs produce, then those the passes name
/// (an unknown name is an error; a known one no material has, a warning), then `emission`.
/// Returns them, the index of `emission` and the warnings.
fn scene_components(
    scene: &Scene,
    programs: &[Program],
) -> Result<(Components, usize, Vec<String>), RenderError> {
    let mut components = Components::of(&programs.iter().collect::<Vec<_>>());
    let mut warnings = Vec::new();
    let check = |name: &str, what: &str, comps: &Components, warnings: &mut Vec<String>| {
        if comps.index(name).is_some() {
            Ok(())
        } else if KNOWN_COMPONENTS.contains(&name) {
            warnings.push(format!(
                "{what}: no material of this scene has the component `{name}`; its layer is black"
            ));
            Ok(())
        } else {
            Err(RenderError::Pass(format!(
                "{what}: unknown render component `{name}` (the scene's materials have: {}; known: {})",
                if comps.names.is_empty() {
                    "none".to_string()
                } else {
                    comps.names.join(", ")
                },
                KNOWN_COMPONENTS.join(", ")
            )))
        }
    };
    for p in &scene.settings.passes {
        if let PassKind::Components(c) = &p.kind {
            for n in c {
                check(n, &format!("pass `{}`", p.name), &components, &mut warnings)?;
            }
        }
    }
    for (i, r) in scene.settings.rules.iter().enumerate() {
        if let RuleAction::Components(c) = &r.action {
            for n in c {
                check(n, &format!("rule {i}"), &components, &mut warnings)?;
            }
        }
    }
    for p in &scene.settings.passes {
        if let PassKind::Components(c) = &p.kind {
            for n in c {
                components.intern(n);
            }
        }
    }
    let emission = components.intern("emission");
    Ok((components, emission, warnings))
}

/// The distinct rule actions over (ray type, depth), each with the ray types it serves,
/// and `table[ray type][depth]`: what hits compute.
fn action_table(s: &Settings) -> (Vec<(RuleAction, u32)>, Vec<Vec<Action>>) {
    let max_depth = s
        .max_reflection_depth
        .max(s.max_refraction_depth)
        .max(s.max_diffuse_depth);
    let mut actions: Vec<(RuleAction, u32)> = Vec::new(); // (action, ray types)
    let mut table = Vec::new();
    for ray in RayMatch::ALL {
        let mut row = Vec::new();
        for depth in 0..=max_depth + 1 {
            let a = action_for(&s.rules, ray, depth);
            let act = match a {
                RuleAction::Override(o) => Action::Override(*o),
                a => {
                    let i = match actions.iter().position(|(b, _)| b == a) {
                        Some(i) => i,
                        None => {
                            actions.push((a.clone(), 0));
                            actions.len() - 1
                        }
                    };
                    actions[i].1 |= ray.code() as u32;
                    Action::Material(i)
                }
            };
            row.push(act);
        }
        table.push(row);
    }
    (actions, table)
}

/// `shaders[material][action]`: each material specialized once per distinct component mask
/// the actions produce (seeing the ray types of every action that produces it) and
/// compiled.
fn compile_materials(
    scene: &Scene,
    programs: &[Program],
    actions: &[(RuleAction, u32)],
    backend: &dyn ShaderBackend,
    components: &Components,
    stats: &mut RenderStats,
    differentials: &mut bool,
) -> Result<Vec<Vec<Specialized>>, RenderError> {
    let mut shaders = Vec::new();
    for (m, program) in scene.materials.iter().zip(programs) {
        // One specialization per distinct mask, seeing the ray types of every action
        // that produces it.
        let masks: Vec<u32> = actions
            .iter()
            .map(|(a, _)| program_mask(program, a))
            .collect();
        let mut compiled: Vec<(u32, Specialized)> = Vec::new();
        for &mask in &masks {
            if compiled.iter().any(|(k, _)| *k == mask) {
                continue;
            }
            let rays = masks
                .iter()
                .zip(actions)
                .filter(|(k, _)| **k == mask)
                .fold(0, |r, (_, (_, rt))| r | rt);
            let spec = Specialization {
                components: mask,
                ray_types: rays,
                ..Specialization::default()
            };
            let (p, report) = opt::run(program, &spec);
            let sp = Specialized::new(&p, mask, &report.needs, backend, components, &m.name)?;
            *differentials |= sp.differentials;
            stats.shaders += 1;
            compiled.push((mask, sp));
        }
        let per = masks
            .iter()
            .filter_map(|mask| {
                compiled
                    .iter()
                    .find(|(k, _)| k == mask)
                    .map(|(_, sp)| sp.clone())
            })
            .collect();
        shaders.push(per);
    }
    Ok(shaders)
}

/// The override shaders the passes and the rules use, compiled.
fn compile_overrides(
    s: &Settings,
    table: &[Vec<Action>],
    backend: &dyn ShaderBackend,
    components: &Components,
    stats: &mut RenderStats,
    differentials: &mut bool,
) -> Result<Vec<(OverrideKind, Specialized)>, RenderError> {
    let mut kinds: Vec<OverrideKind> = s
        .passes
        .iter()
        .filter_map(|p| match p.kind {
            PassKind::Override(o) => Some(o),
            _ => None,
        })
        .collect();
    for row in table {
        for a in row {
            if let Action::Override(o) = a {
                kinds.push(*o);
            }
        }
    }
    kinds.sort();
    kinds.dedup();
    let mut overrides = Vec::new();
    for kind in kinds {
        let name = format!("override:{}", kind.name());
        let p = kind
            .program(s.occlusion_samples, s.occlusion_distance)
            .map_err(|message| RenderError::Compile {
                material: name.clone(),
                message,
            })?;
        let needs = opt::needs::analyze(&p);
        let sp = Specialized::new(&p, u32::MAX, &needs, backend, components, &name)?;
        *differentials |= sp.differentials;
        stats.shaders += 1;
        overrides.push((kind, sp));
    }
    Ok(overrides)
}

/// Per instance, the shading environment: the lights, the camera and the object transform.
fn shade_envs(scene: &Scene) -> Vec<ShadeEnv> {
    let cam_t = Transform::look_at(
        scene.camera.position.to_array(),
        scene.camera.look_at.to_array(),
        scene.camera.up.to_array(),
    )
    .unwrap_or(Transform::IDENTITY);
    let base = ShadeEnv {
        camera: cam_t,
        ..ShadeEnv::with_lights(&scene.lights)
    };
    scene
        .instances
        .iter()
        .map(|inst| ShadeEnv {
            object: Transform::new(row_major(inst.transform.inverse()))
                .unwrap_or(Transform::IDENTITY),
            ..base.clone()
        })
        .collect()
}

fn row_major(m: DMat4) -> [f64; 16] {
    m.transpose().to_cols_array()
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
        let (components, emission, warnings) = scene_components(&scene, &programs)?;
        let s = &scene.settings;
        let (actions, table) = action_table(s);
        let mut differentials = false;
        let shaders = compile_materials(
            &scene,
            &programs,
            &actions,
            backend,
            &components,
            &mut stats,
            &mut differentials,
        )?;
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
        let envs = shade_envs(&scene);
        Ok(Renderer {
            scene,
            camera,
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

    /// Renders every tile on the current rayon pool, calling `progress(done, total)` after
    /// each tile. Returns the film and the statistics.
    pub fn render(&self, progress: &(dyn Fn(u64, u64) + Sync)) -> (Film, RenderStats) {
        let start = Instant::now();
        let (w, h) = (self.scene.camera.width, self.scene.camera.height);
        let ts = self.scene.settings.tile_size;
        let mut tiles = Vec::new();
        for y0 in (0..h).step_by(ts as usize) {
            for x0 in (0..w).step_by(ts as usize) {
                tiles.push((x0, y0, (x0 + ts).min(w), (y0 + ts).min(h)));
            }
        }
        let total = tiles.len() as u64;
        let done = AtomicU64::new(0);
        let layout = self.layout();
        let (outs, tile_stats): (Vec<TileOut>, Vec<TileStats>) = match self.mode {
            ShadingMode::Immediate => tiles
                .par_iter()
                .map(|&(x0, y0, x1, y1)| {
                    let stats = TileStats::default();
                    let out = self.render_tile(x0, y0, x1, y1, &layout, &stats);
                    let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(d, total);
                    (out, stats)
                })
                .unzip(),
            ShadingMode::Deferred(opts) => {
                let spp = self.scene.settings.spp as usize;
                let groups = group_tiles(&tiles, spp, opts.group_samples);
                let results: Vec<(Vec<TileOut>, TileStats)> = groups
                    .par_iter()
                    .map(|g| {
                        let stats = TileStats::default();
                        let outs = self.render_group(&tiles[g.clone()], &layout, &stats);
                        let d = done.fetch_add(g.len() as u64, Ordering::Relaxed) + g.len() as u64;
                        progress(d, total);
                        (outs, stats)
                    })
                    .collect();
                let mut outs = Vec::with_capacity(tiles.len());
                let mut stats = Vec::with_capacity(results.len());
                for (o, s) in results {
                    outs.extend(o);
                    stats.push(s);
                }
                (outs, stats)
            }
        };
        let mut acc = vec![0.0f32; (w as usize) * (h as usize) * layout.stride];
        let mut stats = self.stats.clone();
        for ((x0, y0, x1, _), out) in tiles.iter().zip(outs) {
            let tw = (x1 - x0) as usize;
            for (i, px) in out.values.chunks_exact(layout.stride).enumerate() {
                let (x, y) = (*x0 as usize + i % tw, *y0 as usize + i / tw);
                let dst = (y * w as usize + x) * layout.stride;
                acc[dst..dst + layout.stride].copy_from_slice(px);
            }
        }
        for ts in tile_stats {
            stats.rays += ts.rays.load(Ordering::Relaxed);
            stats.shading_calls += ts.shading_calls.load(Ordering::Relaxed);
            stats.nonfinite += ts.nonfinite.load(Ordering::Relaxed);
            stats.batches += ts.batches.load(Ordering::Relaxed);
            stats.batched_fragments += ts.batched.load(Ordering::Relaxed);
            stats.largest_batch = stats.largest_batch.max(ts.largest.load(Ordering::Relaxed));
            let t = ts
                .times
                .lock()
                .map(|t| *t)
                .unwrap_or_else(|e| *e.into_inner());
            stats.batch_times.add(&t);
        }
        let film = self.compose(&acc, &layout);
        stats.render_time = start.elapsed();
        (film, stats)
    }

    fn layout(&self) -> Layout {
        let ncomp = self.components.names.len();
        // Beauty components (3 each), untagged (3), alpha (1), components from outside the
        // beauty (3 each), then each override pass's channels.
        let mut offset = ncomp * 6 + 4;
        let mut overrides = Vec::new();
        for p in &self.scene.settings.passes {
            if let PassKind::Override(o) = p.kind {
                overrides.push((o, offset));
                offset += o.channels().len();
            }
        }
        let overrides_need_uv = overrides.iter().any(|(o, _)| self.override_needs_uv(*o));
        Layout {
            ncomp,
            overrides,
            overrides_need_uv,
            stride: offset,
        }
    }

    fn compose(&self, acc: &[f32], layout: &Layout) -> Film {
        let (w, h) = (self.scene.camera.width, self.scene.camera.height);
        let n = (w as usize) * (h as usize);
        let px = |i: usize| &acc[i * layout.stride..(i + 1) * layout.stride];
        let mut layers = Vec::new();
        // beauty = every component + untagged values; A = coverage.
        let mut beauty = vec![0.0f32; n * 4];
        for i in 0..n {
            let v = px(i);
            for c in 0..3 {
                let mut s = 0.0f32;
                for k in 0..layout.ncomp {
                    s += v[k * 3 + c];
                }
                s += v[layout.ncomp * 3 + c];
                beauty[i * 4 + c] = s;
            }
            beauty[i * 4 + 3] = v[layout.ncomp * 3 + 3];
        }
        layers.push(Layer::new("beauty", &["R", "G", "B", "A"], beauty));
        for p in &self.scene.settings.passes {
            match &p.kind {
                PassKind::Components(names) => {
                    let ks: Vec<usize> = names
                        .iter()
                        .filter_map(|nm| self.components.index(nm))
                        .collect();
                    let extra = layout.ncomp * 3 + 4;
                    let mut data = vec![0.0f32; n * 3];
                    for i in 0..n {
                        let v = px(i);
                        for c in 0..3 {
                            let mut s = 0.0f32;
                            for &k in &ks {
                                s += v[k * 3 + c] + v[extra + k * 3 + c];
                            }
                            data[i * 3 + c] = s;
                        }
                    }
                    layers.push(Layer::new(&p.name, &["R", "G", "B"], data));
                }
                PassKind::Override(o) => {
                    let off = layout
                        .overrides
                        .iter()
                        .find(|(k, _)| k == o)
                        .map_or(0, |x| x.1);
                    let nc = o.channels().len();
                    let mut data = vec![0.0f32; n * nc];
                    for i in 0..n {
                        data[i * nc..(i + 1) * nc].copy_from_slice(&px(i)[off..off + nc]);
                    }
                    layers.push(Layer::new(&p.name, o.channels(), data));
                }
            }
        }
        Film {
            width: w,
            height: h,
            layers,
        }
    }

    fn render_tile(
        &self,
        x0: u32,
        y0: u32,
        x1: u32,
        y1: u32,
        layout: &Layout,
        stats: &TileStats,
    ) -> TileOut {
        let spp = self.scene.settings.spp;
        let mut values = vec![0.0f32; ((x1 - x0) * (y1 - y0)) as usize * layout.stride];
        let mut sample = vec![0.0f32; layout.stride];
        let mut out = ShadeOut {
            values: Vec::new(),
            nonfinite: 0,
        };
        let inv = 1.0 / spp as f32;
        for y in y0..y1 {
            for x in x0..x1 {
                let i = ((y - y0) * (x1 - x0) + (x - x0)) as usize;
                let dst = &mut values[i * layout.stride..(i + 1) * layout.stride];
                for k in 0..spp {
                    sample.iter_mut().for_each(|v| *v = 0.0);
                    let state = self.camera_ray(x, y, k);
                    self.camera_sample(&state, layout, &mut sample, &mut out, stats);
                    for (d, s) in dst.iter_mut().zip(&sample) {
                        *d += *s;
                    }
                }
                dst.iter_mut().for_each(|v| *v *= inv);
            }
        }
        TileOut { values }
    }

    /// One camera sample into `sample` (the per-pixel layout).
    fn camera_sample(
        &self,
        ray: &RayState,
        layout: &Layout,
        sample: &mut [f32],
        out: &mut ShadeOut<f32>,
        stats: &TileStats,
    ) {
        let Some((action, prep)) = self.camera_hit(ray, layout, sample, stats) else {
            return;
        };
        match action {
            Action::Material(a) => {
                let sp = &self.shaders[prep.material][*a];
                self.shade(sp, ray, &prep, out, stats);
                add_parts(sp, &out.values, layout, sample);
            }
            Action::Override(o) => {
                let v = self.override_value(*o, ray, &prep, out, stats);
                add_override_beauty(v, layout, sample);
            }
        }
        for &(o, off) in &layout.overrides {
            let v = self.override_value(o, ray, &prep, out, stats);
            put_override_pass(o, off, v, sample);
        }
    }

    /// Traces a camera ray: a miss or an emitter fills `sample` and gives `None`; a surface
    /// hit marks the sample covered and gives the action camera hits take and the prepared
    /// hit (shading is the caller's).
    fn camera_hit(
        &self,
        ray: &RayState,
        layout: &Layout,
        sample: &mut [f32],
        stats: &TileStats,
    ) -> Option<(&Action, Prepared)> {
        stats.rays.fetch_add(1, Ordering::Relaxed);
        let em = self.emission * 3;
        let found = self.intersect(ray.o, ray.d);
        let hit = match found {
            Found::Miss => {
                let bg = self.scene.background;
                for c in 0..3 {
                    sample[em + c] += bg[c] as f32;
                }
                return None;
            }
            Found::Emitter(rad) => {
                for c in 0..3 {
                    sample[em + c] += rad[c];
                }
                sample[layout.ncomp * 3 + 3] = 1.0;
                return None;
            }
            Found::Surface(h) => h,
        };
        sample[layout.ncomp * 3 + 3] = 1.0;
        let action = self.action(ray.ray, ray.depth);
        let material = self.material_of(&hit);
        let uv = layout.overrides_need_uv || self.needs_uv(action, material);
        Some((action, self.prepare(ray, &hit, uv)))
    }

    /// The camera ray of sample `k` of pixel `(x, y)`.
    fn camera_ray(&self, x: u32, y: u32, k: u32) -> RayState {
        let spp = self.scene.settings.spp;
        let (jx, jy) = pixel_sample(x, y, k, spp);
        let ray = self
            .camera
            .ray(x as f32 + jx, y as f32 + jy, self.differentials);
        RayState {
            o: ray.o,
            d: ray.d,
            ray: RayMatch::Camera,
            depth: 0,
            seed: hash3(x, y, k),
            diffs: ray.diffs,
        }
    }

    /// The tiles of one group in the deferred mode: trace every camera sample, shade the
    /// hits per shader and environment in batches, then finish each sample as
    /// [`Renderer::camera_sample`] does.
    fn render_group(
        &self,
        tiles: &[(u32, u32, u32, u32)],
        layout: &Layout,
        stats: &TileStats,
    ) -> Vec<TileOut> {
        let spp = self.scene.settings.spp;
        let stride = layout.stride;
        let nsamples: usize = tiles
            .iter()
            .map(|(x0, y0, x1, y1)| ((x1 - x0) * (y1 - y0)) as usize * spp as usize)
            .sum();
        let mut samples = vec![0.0f32; nsamples * stride];
        // 1. Trace: every sample's camera ray; each shading call a hit needs becomes a job
        //    of the batch of its shader and environment.
        let mut jobs: Vec<Job> = Vec::new();
        let mut batches: Vec<BatchKey> = Vec::new();
        let mut batch_of: HashMap<(usize, usize), usize> = HashMap::new();
        let mut s = 0usize;
        for &(x0, y0, x1, y1) in tiles {
            for y in y0..y1 {
                for x in x0..x1 {
                    for k in 0..spp {
                        let ray = self.camera_ray(x, y, k);
                        let sample = &mut samples[s * stride..(s + 1) * stride];
                        if let Some((action, prep)) = self.camera_hit(&ray, layout, sample, stats) {
                            let mut push = |sp: &Specialized, apply: Apply| {
                                let instance = prep.surface.instance as usize;
                                let env = if sp.object_space {
                                    instance
                                } else {
                                    usize::MAX
                                };
                                let key = (Arc::as_ptr(&sp.shader) as *const u8 as usize, env);
                                let batch = *batch_of.entry(key).or_insert_with(|| {
                                    batches.push(BatchKey {
                                        shader: sp.clone(),
                                        instance,
                                        jobs: Vec::new(),
                                    });
                                    batches.len() - 1
                                });
                                batches[batch].jobs.push(jobs.len());
                                jobs.push(Job {
                                    sample: s,
                                    apply,
                                    frag: self.fragment(sp, &ray, &prep),
                                    hit: self.services(&ray, &prep, stats),
                                });
                            };
                            match action {
                                Action::Material(a) => {
                                    push(
                                        &self.shaders[prep.material][*a],
                                        Apply::Parts(prep.material, *a),
                                    );
                                }
                                Action::Override(o) => match self.override_shader(*o) {
                                    Some(sp) => push(sp, Apply::OverrideBeauty(*o)),
                                    None => add_override_beauty([0.0; 3], layout, sample),
                                },
                            }
                            for &(o, off) in &layout.overrides {
                                match self.override_shader(o) {
                                    Some(sp) => push(sp, Apply::OverridePass(o, off)),
                                    None => put_override_pass(o, off, [0.0; 3], sample),
                                }
                            }
                        }
                        s += 1;
                    }
                }
            }
        }
        // 2. Shade: one `shade_many` call per batch.
        let mut results = vec![(0usize, 0usize); jobs.len()]; // (start in `arena`, width)
        let mut arena: Vec<f32> = Vec::new();
        let mut out = Vec::new();
        let mut frags = Vec::new();
        for b in &batches {
            let env = &self.envs[b.instance];
            frags.clear();
            frags.extend(b.jobs.iter().map(|&j| jobs[j].frag));
            let services = BatchServices {
                hits: b.jobs.iter().map(|&j| jobs[j].hit).collect(),
            };
            let r =
                b.shader
                    .shader
                    .shade_many(env, b.shader.mask, Some(&services), &frags, &mut out);
            let n = b.jobs.len() as u64;
            stats.shading_calls.fetch_add(n, Ordering::Relaxed);
            stats.nonfinite.fetch_add(r.nonfinite, Ordering::Relaxed);
            stats.batches.fetch_add(1, Ordering::Relaxed);
            stats.batched.fetch_add(n, Ordering::Relaxed);
            stats.largest.fetch_max(n, Ordering::Relaxed);
            if let Ok(mut t) = stats.times.lock() {
                t.add(&r.times);
            }
            let width = out.len() / b.jobs.len().max(1);
            for (i, &j) in b.jobs.iter().enumerate() {
                results[j] = (arena.len() + i * width, width);
            }
            arena.extend_from_slice(&out[..width * b.jobs.len()]);
        }
        // 3. Finish: apply each job's outputs to its sample, in the order the immediate
        //    path applies them.
        for (job, &(start, width)) in jobs.iter().zip(&results) {
            let values = &arena[start..start + width];
            let sample = &mut samples[job.sample * stride..(job.sample + 1) * stride];
            match job.apply {
                Apply::Parts(m, a) => add_parts(&self.shaders[m][a], values, layout, sample),
                Apply::OverrideBeauty(o) => {
                    add_override_beauty(override_channels(o, values), layout, sample)
                }
                Apply::OverridePass(o, off) => {
                    put_override_pass(o, off, override_channels(o, values), sample)
                }
            }
        }
        // 4. Accumulate the samples into pixels, tile by tile, as `render_tile` does.
        let inv = 1.0 / spp as f32;
        let mut s = 0usize;
        let mut outs = Vec::with_capacity(tiles.len());
        for &(x0, y0, x1, y1) in tiles {
            let n = ((x1 - x0) * (y1 - y0)) as usize;
            let mut values = vec![0.0f32; n * stride];
            for dst in values.chunks_exact_mut(stride) {
                for _ in 0..spp {
                    let sample = &samples[s * stride..(s + 1) * stride];
                    for (d, v) in dst.iter_mut().zip(sample) {
                        *d += *v;
                    }
                    s += 1;
                }
                dst.iter_mut().for_each(|v| *v *= inv);
            }
            outs.push(TileOut { values });
        }
        outs
    }

    fn action(&self, ray: RayMatch, depth: u32) -> &Action {
        let row = &self.table[RayMatch::ALL.iter().position(|r| *r == ray).unwrap_or(0)];
        &row[(depth as usize).min(row.len() - 1)]
    }

    /// The value of an override shader at a hit: its channels (up to 3 floats), a
    /// one-channel value (depth, occlusion) repeated in all three so that an override rule
    /// shows it as grey in the beauty.
    fn override_value(
        &self,
        kind: OverrideKind,
        ray: &RayState,
        prep: &Prepared,
        out: &mut ShadeOut<f32>,
        stats: &TileStats,
    ) -> [f32; 3] {
        let Some(sp) = self.override_shader(kind) else {
            return [0.0; 3];
        };
        self.shade(sp, ray, prep, out, stats);
        override_channels(kind, &out.values)
    }

    /// The compiled override shader of a kind.
    fn override_shader(&self, kind: OverrideKind) -> Option<&Specialized> {
        self.overrides
            .iter()
            .find(|(k, _)| *k == kind)
            .map(|(_, sp)| sp)
    }

    fn intersect(&self, o: Vec3, d: Vec3) -> Found {
        let hit = self.accel.closest(o, d, f32::INFINITY);
        let tmax = hit.map_or(f32::INFINITY, |h| h.t);
        let mut best: Option<(f32, [f32; 3])> = None;
        for e in &self.scene.emitters {
            if let Some(t) = hit_emitter(e, o, d)
                && t < tmax
                && best.is_none_or(|b| t < b.0)
            {
                best = Some((t, e.radiance.map(|x| x as f32)));
            }
        }
        match (best, hit) {
            (Some((_, r)), _) => Found::Emitter(r),
            (None, Some(h)) => Found::Surface(h),
            (None, None) => Found::Miss,
        }
    }

    fn material_of(&self, hit: &Hit) -> usize {
        self.scene.instances[self.accel.instance(hit.prim) as usize].material
    }

    /// Whether the shader an action picks for `material` reads uv or tangents.
    fn needs_uv(&self, action: &Action, material: usize) -> bool {
        match action {
            Action::Material(a) => self.shaders[material][*a].uv_tangents,
            Action::Override(o) => self.override_needs_uv(*o),
        }
    }

    fn override_needs_uv(&self, kind: OverrideKind) -> bool {
        self.overrides
            .iter()
            .any(|(k, s)| *k == kind && s.uv_tangents)
    }

    /// The surface at a hit (uv and tangents only with `uv_tangents`), with facing normals
    /// and transferred differentials.
    fn prepare(&self, ray: &RayState, hit: &Hit, uv_tangents: bool) -> Prepared {
        let surface = self.accel.surface(hit, uv_tangents);
        let ng_facing = if surface.ng.dot(ray.d) <= 0.0 {
            surface.ng
        } else {
            -surface.ng
        };
        let n_facing = if surface.n.dot(ng_facing) >= 0.0 {
            surface.n
        } else {
            -surface.n
        };
        let material = self.scene.instances[surface.instance as usize].material;
        // Igehy's transfer onto the tangent plane: dP = dO + t·dD + dt·D.
        let diffs = ray.diffs.map(|rd| {
            let dn = ray.d.dot(surface.ng);
            let transfer = |d_o: Vec3, d_d: Vec3| -> Vec3 {
                if dn.abs() < 1e-12 {
                    return Vec3::ZERO;
                }
                let dt = -(d_o + hit.t * d_d).dot(surface.ng) / dn;
                let v = d_o + hit.t * d_d + dt * ray.d;
                if v.is_finite() { v } else { Vec3::ZERO }
            };
            HitDiffs {
                dpdx: transfer(rd.dodx, rd.dddx),
                dpdy: transfer(rd.dody, rd.dddy),
                dddx: rd.dddx,
                dddy: rd.dddy,
            }
        });
        Prepared {
            surface,
            ng_facing,
            n_facing,
            material,
            diffs,
        }
    }

    fn services<'a>(
        &'a self,
        ray: &RayState,
        prep: &Prepared,
        stats: &'a TileStats,
    ) -> HitServices<'a> {
        HitServices {
            r: self,
            stats,
            p: prep.surface.p,
            ng_facing: prep.ng_facing,
            n_facing: prep.n_facing,
            d_in: ray.d,
            diffs: prep.diffs,
            seed: ray.seed,
        }
    }

    /// Runs a specialized shader on a prepared hit into `out`.
    fn shade(
        &self,
        sp: &Specialized,
        ray: &RayState,
        prep: &Prepared,
        out: &mut ShadeOut<f32>,
        stats: &TileStats,
    ) {
        let frag = self.fragment(sp, ray, prep);
        let services = self.services(ray, prep, stats);
        let env = &self.envs[prep.surface.instance as usize];
        let ctx = ShadeCtx {
            frag,
            env,
            mask: sp.mask,
            scene: Some(&services),
        };
        sp.shader.shade(&ctx, out);
        stats.shading_calls.fetch_add(1, Ordering::Relaxed);
        stats
            .nonfinite
            .fetch_add(out.nonfinite as u64, Ordering::Relaxed);
    }

    /// The fragment a specialized shader gets at a prepared hit (uv, tangents and
    /// differentials only where it reads them).
    fn fragment(&self, sp: &Specialized, ray: &RayState, prep: &Prepared) -> Fragment {
        let s = &prep.surface;
        let mut frag = Fragment {
            p: s.p.to_array(),
            n: prep.n_facing.to_array(),
            ng: s.ng.to_array(),
            i: (s.p - ray.o).to_array(),
            ray_type: ray.ray.code(),
            ray_depth: ray.depth as i32,
            seed: ray.seed,
            ..Fragment::default()
        };
        if sp.uv_tangents {
            frag.uv = s.uv.to_array();
            frag.dpdu = s.dpdu.to_array();
            frag.dpdv = s.dpdv.to_array();
        }
        if sp.differentials
            && let Some(d) = prep.diffs
        {
            frag.dpdx = d.dpdx.to_array();
            frag.dpdy = d.dpdy.to_array();
        }
        frag
    }

    /// Radiance along a secondary ray: the total of what it hits, shaded with the action
    /// its ray type and depth select.
    fn radiance(&self, ray: &RayState, stats: &TileStats) -> [f32; 3] {
        stats.rays.fetch_add(1, Ordering::Relaxed);
        let hit = match self.intersect(ray.o, ray.d) {
            Found::Miss => return self.scene.background.map(|x| x as f32),
            Found::Emitter(r) => return r,
            Found::Surface(h) => h,
        };
        let action = self.action(ray.ray, ray.depth);
        let uv = self.needs_uv(action, self.material_of(&hit));
        let prep = self.prepare(ray, &hit, uv);
        let mut out = ShadeOut {
            values: Vec::new(),
            nonfinite: 0,
        };
        match action {
            Action::Material(a) => {
                let sp = &self.shaders[prep.material][*a];
                self.shade(sp, ray, &prep, &mut out, stats);
                let mut sum = [0.0f32; 3];
                for part in sp.parts.iter().filter(|p| p.beauty) {
                    for (c, s) in sum.iter_mut().enumerate().take(part.width.min(3)) {
                        *s += out.values[part.offset + c];
                    }
                }
                sum
            }
            Action::Override(o) => self.override_value(*o, ray, &prep, &mut out, stats),
        }
    }

    fn depth_limit(&self, ray: RayMatch) -> u32 {
        let s = &self.scene.settings;
        match ray {
            RayMatch::Camera => 0,
            RayMatch::Reflection => s.max_reflection_depth,
            RayMatch::Refraction => s.max_refraction_depth,
            RayMatch::Diffuse => s.max_diffuse_depth,
        }
    }
}

/// Where the per-pixel floats live.
struct Layout {
    /// Scene components: the first `3·ncomp` floats of a pixel are the beauty's parts,
    /// then 3 untagged, 1 alpha, then `3·ncomp` parts from outside the beauty.
    ncomp: usize,
    overrides: Vec<(OverrideKind, usize)>,
    /// Whether an override pass reads uv or tangents.
    overrides_need_uv: bool,
    stride: usize,
}

struct TileOut {
    values: Vec<f32>,
}

/// Counters of one tile, or one group of tiles in the deferred mode (one thread works it, so
/// they are never contended).
#[derive(Default)]
struct TileStats {
    rays: AtomicU64,
    shading_calls: AtomicU64,
    nonfinite: AtomicU64,
    batches: AtomicU64,
    batched: AtomicU64,
    largest: AtomicU64,
    times: Mutex<BatchTimes>,
}

/// Adds a material's output parts (`values`: one shading call's outputs) to a sample.
fn add_parts(sp: &Specialized, values: &[f32], layout: &Layout, sample: &mut [f32]) {
    for part in &sp.parts {
        let base = match (part.beauty, part.comp) {
            (true, Some(k)) => k * 3,
            (true, None) => layout.ncomp * 3,
            (false, Some(k)) => layout.ncomp * 3 + 4 + k * 3,
            (false, None) => continue,
        };
        for c in 0..part.width.min(3) {
            sample[base + c] += values[part.offset + c];
        }
    }
}

/// An override rule's value goes to the beauty (untagged).
fn add_override_beauty(v: [f32; 3], layout: &Layout, sample: &mut [f32]) {
    for c in 0..3 {
        sample[layout.ncomp * 3 + c] += v[c.min(v.len() - 1)];
    }
}

/// An override pass's channels go to its place in the sample.
fn put_override_pass(kind: OverrideKind, off: usize, v: [f32; 3], sample: &mut [f32]) {
    let nc = kind.channels().len();
    sample[off..off + nc].copy_from_slice(&v[..nc]);
}

/// The value of an override shader from its outputs: its channels (up to 3 floats), a
/// one-channel value (depth, occlusion) repeated in all three so that an override rule
/// shows it as grey in the beauty.
fn override_channels(kind: OverrideKind, values: &[f32]) -> [f32; 3] {
    let mut v = [0.0f32; 3];
    for (d, s) in v.iter_mut().zip(values) {
        *d = *s;
    }
    if kind.channels().len() == 1 {
        v = [v[0]; 3];
    }
    v
}

/// Consecutive tiles (in the given order) grouped until each group holds at least
/// `min_samples` camera samples; every group has at least one tile.
fn group_tiles(
    tiles: &[(u32, u32, u32, u32)],
    spp: usize,
    min_samples: usize,
) -> Vec<std::ops::Range<usize>> {
    let mut groups = Vec::new();
    let (mut start, mut n) = (0usize, 0usize);
    for (i, (x0, y0, x1, y1)) in tiles.iter().enumerate() {
        n += ((x1 - x0) * (y1 - y0)) as usize * spp;
        if n >= min_samples {
            groups.push(start..i + 1);
            start = i + 1;
            n = 0;
        }
    }
    if start < tiles.len() {
        groups.push(start..tiles.len());
    }
    groups
}

/// One deferred shading call: which sample it finishes and how, its fragment and its hit's
/// scene services.
struct Job<'a> {
    sample: usize,
    apply: Apply,
    frag: Fragment,
    hit: HitServices<'a>,
}

/// How a deferred shading call's outputs finish its sample.
#[derive(Clone, Copy, Debug)]
enum Apply {
    /// A material's parts (material, action).
    Parts(usize, usize),
    /// An override rule: the beauty.
    OverrideBeauty(OverrideKind),
    /// An override pass at this offset of the sample.
    OverridePass(OverrideKind, usize),
}

/// The jobs of one shader and environment (`instance`: whose environment; any instance's
/// when the shader does not read object space).
struct BatchKey {
    shader: Specialized,
    instance: usize,
    jobs: Vec<usize>,
}

/// The scene services of a batch (see the module documentation): fragment `i`'s own
/// services through [`SceneServices::fragment`]; a direct call (a ray that belongs to no
/// fragment of the batch) gets detached services: the ray starts where asked, with a seed
/// hashed from the origin and no differentials.
struct BatchServices<'a> {
    hits: Vec<HitServices<'a>>,
}

impl<'a> BatchServices<'a> {
    /// Services for a ray from `origin` that belongs to no fragment.
    fn detached(&self, origin: [f32; 3]) -> HitServices<'a> {
        HitServices {
            p: Vec3::NAN,
            ng_facing: Vec3::ZERO,
            n_facing: Vec3::ZERO,
            d_in: Vec3::ZERO,
            diffs: None,
            seed: hash3(
                origin[0].to_bits(),
                origin[1].to_bits(),
                origin[2].to_bits(),
            ),
            ..self.hits[0]
        }
    }
}

impl SceneServices for BatchServices<'_> {
    fn trace(&self, origin: [f32; 3], dir: [f32; 3], ray_type: i32, depth: i32) -> [f32; 3] {
        self.detached(origin).trace(origin, dir, ray_type, depth)
    }

    fn occluded(&self, from: [f32; 3], to: [f32; 3]) -> bool {
        self.detached(from).occluded(from, to)
    }

    fn occlusion(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        samples: u32,
        max_distance: f32,
        seed: u32,
    ) -> f32 {
        self.detached(p)
            .occlusion(p, n, samples, max_distance, seed)
    }

    fn fragment(&self, index: usize) -> Option<&dyn SceneServices> {
        self.hits.get(index).map(|h| h as &dyn SceneServices)
    }
}

enum Found {
    Miss,
    Emitter([f32; 3]),
    Surface(Hit),
}

#[derive(Clone, Copy, Debug)]
struct HitDiffs {
    dpdx: Vec3,
    dpdy: Vec3,
    dddx: Vec3,
    dddy: Vec3,
}

#[derive(Clone, Copy, Debug)]
struct RayState {
    o: Vec3,
    d: Vec3,
    ray: RayMatch,
    depth: u32,
    seed: u32,
    diffs: Option<RayDiffs>,
}

struct Prepared {
    surface: crate::accel::Surface,
    ng_facing: Vec3,
    n_facing: Vec3,
    material: usize,
    diffs: Option<HitDiffs>,
}

/// The scene services of one hit: secondary rays start from its point with a robust
/// offset, and carry its differentials.
#[derive(Clone, Copy)]
struct HitServices<'a> {
    r: &'a Renderer,
    stats: &'a TileStats,
    p: Vec3,
    ng_facing: Vec3,
    n_facing: Vec3,
    d_in: Vec3,
    diffs: Option<HitDiffs>,
    seed: u32,
}

impl HitServices<'_> {
    /// The start of a ray from `origin` towards `dir`: the hit point offset to the side
    /// `dir` leaves on, when `origin` is the hit point (never for detached services, whose
    /// point is NaN).
    fn start(&self, origin: Vec3, dir: Vec3) -> Vec3 {
        let tol = 1e-4 * (1.0 + self.p.abs().max_element());
        if self.p.is_finite() && (origin - self.p).abs().max_element() <= tol {
            let side = if dir.dot(self.ng_facing) >= 0.0 {
                self.ng_facing
            } else {
                -self.ng_facing
            };
            crate::accel::offset_origin(self.p, side)
        } else {
            origin
        }
    }

    /// The differentials of a secondary ray leaving this hit along `dir`.
    fn child_diffs(&self, ray: RayMatch, dir: Vec3) -> Option<RayDiffs> {
        let d = self.diffs?;
        let n = self.n_facing;
        let din = self.d_in;
        let (dddx, dddy) = match ray {
            // r = d − 2(d·n)n, flat normal: dr = dd − 2(dd·n)n.
            RayMatch::Reflection => (
                d.dddx - 2.0 * d.dddx.dot(n) * n,
                d.dddy - 2.0 * d.dddy.dot(n) * n,
            ),
            // Igehy's refraction: dT = η·dD − dμ·n, with η = sinθt / sinθi recovered from the
            // two directions and dμ = (η − η²(D·n)/(T·n))·d(D·n).
            RayMatch::Refraction => {
                let (di, dt) = (din.dot(n), dir.dot(n));
                let sin_i = din.cross(n).length();
                let sin_t = dir.cross(n).length();
                let eta = if sin_i > 1e-6 { sin_t / sin_i } else { 1.0 };
                let k = if dt.abs() > 1e-6 {
                    eta - eta * eta * di / dt
                } else {
                    0.0
                };
                (
                    eta * d.dddx - k * d.dddx.dot(n) * n,
                    eta * d.dddy - k * d.dddy.dot(n) * n,
                )
            }
            _ => return None,
        };
        let v = RayDiffs {
            dodx: d.dpdx,
            dddx,
            dody: d.dpdy,
            dddy,
        };
        [v.dodx, v.dddx, v.dody, v.dddy]
            .iter()
            .all(|x| x.is_finite())
            .then_some(v)
    }
}

impl SceneServices for HitServices<'_> {
    fn trace(&self, origin: [f32; 3], dir: [f32; 3], ray_type: i32, depth: i32) -> [f32; 3] {
        let Some(ray) = RayMatch::from_code(ray_type) else {
            return [0.0; 3];
        };
        let depth = depth.max(0) as u32;
        if ray == RayMatch::Camera || depth > self.r.depth_limit(ray) {
            return [0.0; 3];
        }
        let d = Vec3::from(dir).normalize_or_zero();
        let o = Vec3::from(origin);
        if d == Vec3::ZERO || !o.is_finite() {
            return [0.0; 3];
        }
        let state = RayState {
            o: self.start(o, d),
            d,
            ray,
            depth,
            seed: hash3(
                self.seed,
                (ray_type as u32) << 8 | depth,
                d.x.to_bits() ^ d.y.to_bits().rotate_left(11) ^ d.z.to_bits().rotate_left(22),
            ),
            diffs: self.child_diffs(ray, d),
        };
        self.r.radiance(&state, self.stats)
    }

    fn occluded(&self, from: [f32; 3], to: [f32; 3]) -> bool {
        self.stats.rays.fetch_add(1, Ordering::Relaxed);
        let (from, to) = (Vec3::from(from), Vec3::from(to));
        let v = to - from;
        let dist = v.length();
        if !(dist.is_finite() && dist > 0.0) {
            return false;
        }
        let d = v / dist;
        let o = self.start(from, d);
        // Stop just short of the light sample so the light's own surface never blocks it.
        let tmax = (to - o).length() * (1.0 - 1e-4);
        self.r.accel.occluded(o, d, tmax)
    }

    fn occlusion(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        samples: u32,
        max_distance: f32,
        seed: u32,
    ) -> f32 {
        let n = Vec3::from(n).normalize_or_zero();
        let p = Vec3::from(p);
        if n == Vec3::ZERO || samples == 0 || !p.is_finite() {
            return 1.0;
        }
        let (t, b) = orthonormal(n);
        let o = self.start(p, n);
        let max_distance = if max_distance > 0.0 {
            max_distance
        } else {
            0.0
        };
        let mut open = 0u32;
        for k in 0..samples {
            // Cosine-weighted (Malley): uniform on the disk, projected up.
            let [u1, u2] = shadenet_runtime::lights::random2(seed, 0x0cc1_u32, k);
            let r = u1.sqrt() as f32;
            let phi = (2.0 * std::f64::consts::PI * u2) as f32;
            let z = (1.0 - u1).max(0.0).sqrt() as f32;
            let d = (t * (r * math::cos_f32(phi)) + b * (r * math::sin_f32(phi)) + n * z)
                .normalize_or_zero();
            self.stats.rays.fetch_add(1, Ordering::Relaxed);
            if !self.r.accel.occluded(o, d, max_distance) {
                open += 1;
            }
        }
        open as f32 / samples as f32
    }
}

/// One-sided quad hit distance (from the emitting side).
fn hit_emitter(e: &Emitter, o: Vec3, d: Vec3) -> Option<f32> {
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let n = e.edge_u.cross(e.edge_v);
    let dn = d.dot(n);
    if dn >= 0.0 {
        return None; // from behind or parallel
    }
    let t = (e.corner - o).dot(n) / dn;
    if t.is_nan() || t <= 0.0 {
        return None;
    }
    let q = o + d * t - e.corner;
    let (uu, vv, uv) = (
        e.edge_u.length_squared(),
        e.edge_v.length_squared(),
        e.edge_u.dot(e.edge_v),
    );
    let (qu, qv) = (q.dot(e.edge_u), q.dot(e.edge_v));
    let det = uu * vv - uv * uv;
    let s = (qu * vv - qv * uv) / det;
    let r = (qv * uu - qu * uv) / det;
    ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&r)).then_some(t as f32)
}

/// A 32-bit hash of three words (a counter-based generator: no state).
pub fn hash3(a: u32, b: u32, c: u32) -> u32 {
    let mut h = a
        .wrapping_mul(0x9e37_79b1)
        .wrapping_add(b.wrapping_mul(0x85eb_ca77))
        .wrapping_add(c.wrapping_mul(0xc2b2_ae3d))
        ^ 0x27d4_eb2f;
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297a_2d39);
    h ^= h >> 15;
    h
}

/// The offset of sample `k` inside pixel `(x, y)`: the centre for one sample per pixel,
/// else the R2 sequence rotated by a per-pixel hash (Cranley–Patterson).
pub fn pixel_sample(x: u32, y: u32, k: u32, spp: u32) -> (f32, f32) {
    if spp <= 1 {
        return (0.5, 0.5);
    }
    const A1: f64 = 0.754_877_666_246_692_7; // 1/φ₂
    const A2: f64 = 0.569_840_290_998_053_3; // 1/φ₂²
    let h = hash3(x, y, 0xa5a5_a5a5);
    let r0 = (h >> 16) as f64 / 65536.0;
    let r1 = (h & 0xffff) as f64 / 65536.0;
    let fx = (0.5 + A1 * k as f64 + r0).fract();
    let fy = (0.5 + A2 * k as f64 + r1).fract();
    (fx as f32, fy as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::InterpBackend;
    use shadenet_graph::ir::{Builder, RAY_REFLECTION, RAY_SHADOW};
    use shadenet_graph::{NodeLibrary, compile_json};
    use std::path::Path;

    fn scene(text: &str) -> Scene {
        crate::scene::parse(text, Path::new("test.toml")).unwrap_or_else(|e| panic!("{e}"))
    }

    fn lambert(rgb: [f64; 3]) -> Program {
        let src = format!(
            r#"{{ "nodes": [ {{ "name": "s", "type": "lambert",
                 "inputs": {{ "color": [{}, {}, {}], "diffuse": 1.0 }} }} ],
                 "outputs": {{ "color": "s.outColor" }} }}"#,
            rgb[0], rgb[1], rgb[2]
        );
        compile_json(&src, &NodeLibrary::standard())
            .unwrap()
            .program
    }

    /// A program whose one output is a stream (to look at what the tracer fills in).
    fn stream_program(s: Stream) -> Program {
        let mut b = Builder::new("probe");
        let v = b.stream(s);
        b.output("value", None, v);
        b.finish().unwrap()
    }

    const PLANE: &str = r#"
[camera]
position = [0, 0, 2]
look_at = [0, 0, 0]
fov = 30
resolution = [5, 5]

[materials.m]
json = '{"nodes": [], "outputs": {}}'

[meshes.q]
type = "quad"

[[instances]]
mesh = "q"
material = "m"
"#;

    fn render_one(text: &str, program: Program) -> (Renderer, Film) {
        let r = Renderer::new(scene(text), vec![program], &InterpBackend).unwrap();
        let film = r.render(&|_, _| {}).0;
        (r, film)
    }

    #[test]
    fn ray_differentials_reach_the_shader_when_it_reads_them() {
        let (r, film) = render_one(PLANE, stream_program(Stream::DPdx));
        assert!(r.differentials);
        let b = film.layer("beauty").unwrap();
        // One pixel at distance 2 with a 30° vertical field over 5 pixels.
        let footprint = 2.0 * 2.0 * (15.0f32.to_radians()).tan() / 5.0;
        assert!(
            (b.at(12, 0) - footprint).abs() < 1e-5 * footprint.max(1.0),
            "{}",
            b.at(12, 0)
        );
        assert!(b.at(12, 1).abs() < 1e-6 && b.at(12, 2).abs() < 1e-6);
        let (_, film) = render_one(PLANE, stream_program(Stream::DPdy));
        let b = film.layer("beauty").unwrap();
        assert!((b.at(12, 1) + footprint).abs() < 1e-5, "{}", b.at(12, 1));
    }

    #[test]
    fn uv_and_tangents_are_computed_only_when_needed() {
        let (r, film) = render_one(PLANE, stream_program(Stream::Uv));
        assert!(r.shaders[0][0].uv_tangents && !r.differentials);
        let b = film.layer("beauty").unwrap();
        assert!((b.at(12, 0) - 0.5).abs() < 1e-6 && (b.at(12, 1) - 0.5).abs() < 1e-6);
        let (_, film) = render_one(PLANE, stream_program(Stream::DPdu));
        let b = film.layer("beauty").unwrap();
        assert!(
            (b.at(12, 0) - 2.0).abs() < 1e-5,
            "dPdu of the [-1,1] quad over u in [0,1]"
        );
        let (r, _) = render_one(PLANE, lambert([0.5; 3]));
        assert!(!r.shaders[0][0].uv_tangents && !r.differentials);
    }

    #[test]
    fn camera_hits_see_camera_ray_type_and_depth_zero() {
        let (_, film) = render_one(PLANE, stream_program(Stream::RayType));
        let b = film.layer("beauty").unwrap();
        assert_eq!(b.at(12, 0), RayMatch::Camera.code() as f32);
        let (_, film) = render_one(PLANE, stream_program(Stream::RayDepth));
        assert_eq!(film.layer("beauty").unwrap().at(12, 0), 0.0);
    }

    fn services<'a>(r: &'a Renderer, stats: &'a TileStats, p: Vec3, n: Vec3) -> HitServices<'a> {
        HitServices {
            r,
            stats,
            p,
            ng_facing: n,
            n_facing: n,
            d_in: -n,
            diffs: None,
            seed: 7,
        }
    }

    /// `trace` shades what a secondary ray hits (recursively, as that ray type and depth),
    /// returns black past the depth limit and for shadow rays, and the background on a miss.
    #[test]
    fn trace_shades_the_hit_and_respects_depth_limits() {
        let text = format!(
            "{PLANE}\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = 4\n\
             [[lights]]\ntype = \"environment\"\nintensity = 0.25\nsamples = 1\n"
        );
        let rho = [0.8, 0.4, 0.2];
        let r = Renderer::new(scene(&text), vec![lambert(rho)], &InterpBackend).unwrap();
        let stats = TileStats::default();
        let s = services(&r, &stats, Vec3::new(0.0, 0.0, 1.0), Vec3::Z);
        let got = s.trace([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], RAY_REFLECTION, 1);
        // Point light at distance 2 straight above, plus the environment's uniform sample
        // from some direction: check the point-light part by removing the environment.
        let text2 =
            format!("{PLANE}\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = 4\n");
        let r2 = Renderer::new(scene(&text2), vec![lambert(rho)], &InterpBackend).unwrap();
        let s2 = services(&r2, &stats, Vec3::new(0.0, 0.0, 1.0), Vec3::Z);
        let direct = s2.trace([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], RAY_REFLECTION, 1);
        for c in 0..3 {
            let want = rho[c] / std::f64::consts::PI * 4.0 / 4.0;
            assert!(
                ((direct[c] as f64) - want).abs() < 1e-5 * want,
                "{direct:?}"
            );
            assert!(got[c] >= direct[c]);
        }
        // Past the limit (4 by default): black.
        assert_eq!(
            s2.trace([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], RAY_REFLECTION, 5),
            [0.0; 3]
        );
        assert_eq!(
            s2.trace([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], RAY_SHADOW, 1),
            [0.0; 3]
        );
        // A miss sees the environment.
        assert_eq!(
            s.trace([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], RAY_REFLECTION, 1),
            [0.25; 3]
        );
        assert!(stats.shading_calls.load(Ordering::Relaxed) >= 2);
    }

    const ROOM: &str = r#"
[camera]
position = [0, 3, 3]
look_at = [0, 0, 0]
resolution = [4, 4]

[materials.m]
json = '{"nodes": [], "outputs": {}}'

[meshes.q]
type = "quad"

[[instances]]
mesh = "q"
material = "m"
rotate = [-90, 0, 0]
scale = 10

[[instances]]
mesh = "q"
material = "m"
translate = [0, 0.5, 0]
rotate = [90, 0, 0]
scale = 10
"#;

    #[test]
    fn occlusion_and_shadow_rays_see_the_geometry() {
        let r = Renderer::new(scene(ROOM), vec![lambert([0.5; 3])], &InterpBackend).unwrap();
        let stats = TileStats::default();
        let p = Vec3::ZERO; // on the floor, under a ceiling 0.5 above
        let s = services(&r, &stats, p, Vec3::Y);
        let n = [0.0, 1.0, 0.0];
        assert_eq!(
            s.occlusion(p.to_array(), n, 64, 0.3, 1),
            1.0,
            "ceiling out of reach"
        );
        let closed = s.occlusion(p.to_array(), n, 64, 2.0, 1);
        assert!(closed < 0.05, "{closed}");
        assert_eq!(
            closed,
            s.occlusion(p.to_array(), n, 64, 2.0, 1),
            "deterministic"
        );
        // Half open: only within reach for directions steeper than 60° from the horizon.
        let part = s.occlusion(p.to_array(), n, 256, 0.5 / 30f32.to_radians().cos(), 3);
        assert!(part > 0.0 && part < 1.0, "{part}");
        // Shadow rays: to a point above the ceiling (blocked) and below it (free).
        assert!(s.occluded(p.to_array(), [0.3, 2.0, 0.1]));
        assert!(!s.occluded(p.to_array(), [0.3, 0.4, 0.1]));
        // From the hit point itself, the offset keeps the floor from shadowing itself at
        // grazing angles.
        assert!(!s.occluded(p.to_array(), [5.0, 0.01, 0.0]));
    }

    #[test]
    fn rules_pick_components_and_overrides_per_ray_type() {
        let base = format!(
            "{PLANE}\n[render]\npasses = [\"diffuse\", \"indirect\"]\n\
             [[lights]]\ntype = \"point\"\nposition = [0, 0, 2]\nintensity = 4\n\
             [[lights]]\ntype = \"ambient\"\nintensity = 0.5\n"
        );
        let (r, film) = render_one(&base, lambert([0.5; 3]));
        assert_eq!(r.stats.shaders, 1);
        let ind = film.layer("indirect").unwrap().at(12, 0);
        assert!(ind > 0.2, "{ind}");
        // Camera rays keep only `diffuse`: beauty is the diffuse pass; the material is
        // specialized twice (camera: diffuse; deeper rays: everything).
        let text = base.replace(
            "passes = [\"diffuse\", \"indirect\"]\n",
            "passes = [\"diffuse\", \"indirect\"]\n\n[[render.rules]]\nray = \"camera\"\ncomponents = [\"diffuse\"]\n",
        );
        let (r, film) = render_one(&text, lambert([0.5; 3]));
        assert_eq!(r.stats.shaders, 2);
        let (b, d) = (
            film.layer("beauty").unwrap(),
            film.layer("diffuse").unwrap(),
        );
        assert_eq!(b.at(12, 0), d.at(12, 0));
        assert_eq!(film.layer("indirect").unwrap().at(12, 0), 0.0);
        // An override rule: camera hits shade with the normal shader.
        let text = base.replace(
            "passes = [\"diffuse\", \"indirect\"]\n",
            "passes = [\"diffuse\", \"indirect\"]\n\n[[render.rules]]\nray = \"camera\"\noverride = \"normal\"\n",
        );
        let (_, film) = render_one(&text, lambert([0.5; 3]));
        let b = film.layer("beauty").unwrap();
        assert_eq!([b.at(12, 0), b.at(12, 1), b.at(12, 2)], [0.0, 0.0, 1.0]);
        // A one-channel override (occlusion: 1 over the open plane; depth: 2) shows grey.
        for (kind, v) in [("occlusion", 1.0), ("depth", 2.0)] {
            let (_, film) = render_one(
                &text.replace("\"normal\"", &format!("\"{kind}\"")),
                lambert([0.5; 3]),
            );
            let b = film.layer("beauty").unwrap();
            for c in 0..3 {
                assert!((b.at(12, c) - v).abs() < 1e-5, "{kind}: {}", b.at(12, c));
            }
        }
    }

    #[test]
    fn unknown_pass_components_are_errors_and_known_ones_warnings() {
        // Lambert has no specular part: a known component it lacks is a warning.
        let text = format!("{PLANE}\n[render]\npasses = [\"specular\", \"diffuse\"]\n");
        let r = Renderer::new(scene(&text), vec![lambert([0.5; 3])], &InterpBackend).unwrap();
        assert_eq!(r.warnings().len(), 1, "{:?}", r.warnings());
        assert!(r.warnings()[0].contains("specular"));
        let text = format!("{PLANE}\n[render]\npasses = [\"difuse\"]\n");
        let e = Renderer::new(scene(&text), vec![lambert([0.5; 3])], &InterpBackend)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("difuse") && e.contains("diffuse"), "{e}");
    }

    /// Reflection mirrors the direction differentials about the normal; a refraction that
    /// does not bend (η = 1) keeps them; diffuse rays drop them.
    #[test]
    fn differentials_follow_reflection_and_refraction() {
        let r = Renderer::new(scene(PLANE), vec![lambert([0.5; 3])], &InterpBackend).unwrap();
        let stats = TileStats::default();
        let mut s = services(&r, &stats, Vec3::ZERO, Vec3::Z);
        s.diffs = Some(HitDiffs {
            dpdx: Vec3::new(0.01, 0.0, 0.0),
            dpdy: Vec3::new(0.0, 0.01, 0.0),
            dddx: Vec3::new(0.02, 0.0, 0.003),
            dddy: Vec3::new(0.0, 0.02, 0.0),
        });
        let refl = s.child_diffs(RayMatch::Reflection, Vec3::Z).unwrap();
        assert_eq!(refl.dodx, Vec3::new(0.01, 0.0, 0.0));
        assert!((refl.dddx - Vec3::new(0.02, 0.0, -0.003)).length() < 1e-7);
        assert_eq!(refl.dddy, Vec3::new(0.0, 0.02, 0.0));
        let straight = s.child_diffs(RayMatch::Refraction, -Vec3::Z).unwrap();
        assert!((straight.dddx - Vec3::new(0.02, 0.0, 0.003)).length() < 1e-7);
        assert!(s.child_diffs(RayMatch::Diffuse, Vec3::Z).is_none());
    }

    #[test]
    fn override_passes_report_normal_depth_uv_and_occlusion() {
        let text =
            format!("{PLANE}\n[render]\npasses = [\"normal\", \"depth\", \"uv\", \"occlusion\"]\n");
        let (_, film) = render_one(&text, lambert([0.5; 3]));
        let names: Vec<&str> = film.layers.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["beauty", "normal", "depth", "uv", "occlusion"]);
        let l = |n: &str| film.layer(n).unwrap();
        assert_eq!(l("normal").channels, ["X", "Y", "Z"]);
        assert_eq!(
            [
                l("normal").at(12, 0),
                l("normal").at(12, 1),
                l("normal").at(12, 2)
            ],
            [0.0, 0.0, 1.0]
        );
        assert_eq!(l("depth").channels, ["Z"]);
        assert!(
            (l("depth").at(12, 0) - 2.0).abs() < 1e-5,
            "{}",
            l("depth").at(12, 0)
        );
        assert!((l("uv").at(12, 0) - 0.5).abs() < 1e-6 && (l("uv").at(12, 1) - 0.5).abs() < 1e-6);
        assert_eq!(l("occlusion").at(12, 0), 1.0, "nothing above the plane");
    }

    /// The occlusion override is a built program around the IR's `occlusion` op, compiled
    /// and run by the back end like the other overrides; at every camera hit its value is,
    /// bit for bit, what the tracer's occlusion service answers when asked directly with the
    /// hit's point, facing normal and seed and the scene's settings (what the pass computed
    /// before it was a program).
    #[test]
    fn the_occlusion_pass_is_a_program_asking_the_occlusion_service() {
        use shadenet_graph::ir::Op;
        let p = OverrideKind::Occlusion.program(32, 0.8).unwrap();
        let ops: Vec<&Op> = p.exprs.iter().map(|e| &e.op).collect();
        assert!(ops.iter().any(|o| matches!(o, Op::Occlusion { .. })), "{p}");
        let text = r#"
[camera]
position = [0, 2.5, 3]
look_at = [0, 0.2, 0]
resolution = [12, 12]

[render]
passes = ["occlusion"]
occlusion_samples = 32
occlusion_distance = 0.8

[materials.m]
json = '{"nodes": [], "outputs": {}}'

[meshes.q]
type = "quad"

[meshes.cube]
type = "box"

[[instances]]
mesh = "q"
material = "m"
rotate = [-90, 0, 0]
scale = 3

[[instances]]
mesh = "cube"
material = "m"
translate = [0, 0.4, 0]
scale = 0.4
"#;
        let (r, film) = render_one(text, lambert([0.5; 3]));
        assert_eq!(r.stats.shaders, 2, "the material and the occlusion program");
        let occ = film.layer("occlusion").unwrap();
        let stats = TileStats::default();
        let (mut partial, mut hits) = (0, 0);
        for y in 0..12u32 {
            for x in 0..12u32 {
                let i = (y * 12 + x) as usize;
                let cam = r.camera.ray(x as f32 + 0.5, y as f32 + 0.5, false);
                let state = RayState {
                    o: cam.o,
                    d: cam.d,
                    ray: RayMatch::Camera,
                    depth: 0,
                    seed: hash3(x, y, 0),
                    diffs: None,
                };
                let Found::Surface(hit) = r.intersect(cam.o, cam.d) else {
                    assert_eq!(occ.at(i, 0), 0.0, "a miss has no occlusion");
                    continue;
                };
                let prep = r.prepare(&state, &hit, false);
                let want = r.services(&state, &prep, &stats).occlusion(
                    prep.surface.p.to_array(),
                    prep.n_facing.to_array(),
                    32,
                    0.8,
                    state.seed,
                );
                assert_eq!(occ.at(i, 0).to_bits(), want.to_bits(), "pixel ({x}, {y})");
                hits += 1;
                if want > 0.0 && want < 1.0 {
                    partial += 1;
                }
            }
        }
        assert!(
            hits >= 100 && partial >= 10,
            "{hits} hits, {partial} partly occluded"
        );
    }

    /// Films and statistics of one scene rendered immediately and deferred (with groups of
    /// `group` samples) are identical, bit for bit, on every layer.
    fn assert_deferred_matches(text: &str, program: Program, group: usize) -> RenderStats {
        let mut r = Renderer::new(scene(text), vec![program], &InterpBackend).unwrap();
        assert_eq!(r.shading_mode(), ShadingMode::Immediate);
        let (a, sa) = r.render(&|_, _| {});
        r.set_shading_mode(ShadingMode::Deferred(DeferredOptions {
            group_samples: group,
        }));
        let (b, sb) = r.render(&|_, _| {});
        for (la, lb) in a.layers.iter().zip(&b.layers) {
            assert_eq!(la.name, lb.name);
            let differ = la
                .data
                .iter()
                .zip(&lb.data)
                .filter(|(x, y)| x.to_bits() != y.to_bits())
                .count();
            assert_eq!(differ, 0, "layer {}: {differ} values differ", la.name);
        }
        assert_eq!(a.layers.len(), b.layers.len());
        assert_eq!(
            (sa.rays, sa.shading_calls, sa.nonfinite),
            (sb.rays, sb.shading_calls, sb.nonfinite)
        );
        assert_eq!(sa.batches, 0);
        assert!(sb.batches > 0 && sb.batched_fragments > 0, "{sb:?}");
        sb
    }

    /// A floor with a box on it, partly out of frame (misses see the background), lit by a
    /// point light and a quad light (shadow rays from inside the batch), in passes with
    /// override passes (occlusion asks the scene from inside the batch); 3 spp, tiles of
    /// 2×2 over a 9×7 frame (partial tiles).
    const BOX_ON_FLOOR: &str = r#"
[camera]
position = [0, 2.5, 3]
look_at = [0, 0.2, 0]
resolution = [9, 7]

[render]
spp = 3
tile_size = 2
passes = ["diffuse", "normal", "depth", "uv", "occlusion"]
occlusion_samples = 8
occlusion_distance = 0.8

[materials.m]
json = '{"nodes": [], "outputs": {}}'

[meshes.q]
type = "quad"

[meshes.cube]
type = "box"

[[instances]]
mesh = "q"
material = "m"
rotate = [-90, 0, 0]
scale = 1.5

[[instances]]
mesh = "cube"
material = "m"
translate = [0.2, 0.4, 0]
scale = 0.4

[[lights]]
type = "point"
position = [0.8, 1.5, 0.6]
intensity = 3

[[lights]]
type = "quad"
corner = [-0.3, 1.8, -0.3]
edge_u = [0.6, 0, 0]
edge_v = [0, 0, 0.6]
intensity = 2
samples = 3
"#;

    /// The deferred mode gives the immediate mode's image, bit for bit, on every layer, and
    /// the same statistics, for groups of one tile, several tiles and the whole frame; an
    /// override rule on camera rays shades the override in the batch.
    #[test]
    fn deferred_shading_gives_the_immediate_image() {
        for group in [1, 20, 1 << 20] {
            let st = assert_deferred_matches(BOX_ON_FLOOR, lambert([0.6, 0.5, 0.4]), group);
            // Every camera hit's shading calls went through batches: material and four
            // override passes per hit.
            assert_eq!(st.batched_fragments, st.shading_calls, "{st:?}");
            assert!(st.largest_batch > 1);
        }
        let rule = format!(
            "{BOX_ON_FLOOR}\n[[render.rules]]\nray = \"camera\"\noverride = \"occlusion\"\n"
        );
        assert_deferred_matches(&rule, lambert([0.6, 0.5, 0.4]), 30);
        // A material reading object space is batched per instance.
        let st = assert_deferred_matches(BOX_ON_FLOOR, object_p(), 1 << 20);
        assert!(st.batches >= 2, "{st:?}");
    }

    /// A program whose output is `P` in object space.
    fn object_p() -> Program {
        let src = r#"{ "nodes": [ { "name": "i", "type": "samplerInfo",
             "inputs": { "space": "object" } } ],
             "outputs": { "color": "i.P" } }"#;
        compile_json(src, &NodeLibrary::standard())
            .unwrap_or_else(|e| panic!("{e}"))
            .program
    }

    /// A batch's services give each fragment its own services by index (`fragment`); a
    /// direct call gets detached services (no hit point, a seed from the origin).
    #[test]
    fn batch_services_give_each_fragment_its_own() {
        let r = Renderer::new(scene(ROOM), vec![lambert([0.5; 3])], &InterpBackend).unwrap();
        let stats = TileStats::default();
        let a = services(&r, &stats, Vec3::ZERO, Vec3::Y);
        let mut b = services(&r, &stats, Vec3::new(0.2, 0.0, 0.1), Vec3::Y);
        b.seed = 99;
        let bs = BatchServices { hits: vec![a, b] };
        assert!(bs.fragment(1).is_some() && bs.fragment(2).is_none());
        assert!(bs.detached([0.2, 0.0, 0.1]).p.is_nan());
        assert_ne!(bs.detached([0.2, 0.0, 0.1]).seed, 99);
        // From the fragment's own point the ray is offset: the floor does not shadow its own
        // point at a grazing angle.
        assert!(
            !bs.fragment(0)
                .unwrap()
                .occluded([0.0, 0.0, 0.0], [5.0, 0.01, 0.0])
        );
    }

    #[test]
    fn tiles_group_until_enough_samples() {
        let tiles: Vec<_> = (0..5).map(|i| (i * 2, 0, i * 2 + 2, 2)).collect();
        assert_eq!(group_tiles(&tiles, 1, 8), vec![0..2, 2..4, 4..5]);
        assert_eq!(
            group_tiles(&tiles, 2, 1),
            vec![0..1, 1..2, 2..3, 3..4, 4..5]
        );
        assert_eq!(group_tiles(&tiles, 1, 1000), vec![0..5]);
        assert!(group_tiles(&[], 1, 8).is_empty());
    }

    /// A component the first output lacks comes from another output (as a surface's
    /// `outShadow` will): it fills its pass but stays out of the beauty.
    #[test]
    fn components_outside_the_first_output_fill_passes_not_beauty() {
        let src = r#"{ "nodes": [
            { "name": "m", "type": "lambert", "inputs": { "color": [0.5, 0.5, 0.5], "diffuse": 1.0 } },
            { "name": "p", "type": "phong", "inputs": { "specularColor": 0.5, "cosinePower": 1 } } ],
            "outputs": { "color": "m.outColor", "extra": "p.outColor" } }"#;
        let program = compile_json(src, &NodeLibrary::standard()).unwrap().program;
        let text = format!(
            "{PLANE}\n[render]\npasses = [\"diffuse\", \"specular\"]\n\
             [[lights]]\ntype = \"point\"\nposition = [0.5, 0, 2]\nintensity = 4\n"
        );
        let (_, film) = render_one(&text, program);
        let l = |n: &str| film.layer(n).unwrap().at(12, 0);
        assert!(l("specular") > 0.01, "{}", l("specular"));
        assert_eq!(
            l("beauty"),
            l("diffuse"),
            "specular is not in the first output"
        );
        // The diffuse pass is the first output's, not the sum with the other output's.
        let lambert_only = render_one(&text, lambert([0.5; 3])).1;
        assert_eq!(
            l("diffuse"),
            lambert_only.layer("diffuse").unwrap().at(12, 0)
        );
    }
}
