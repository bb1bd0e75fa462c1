//! Compiling for a render: the scene's render components, the table of what hits compute
//! per ray type and depth, each material specialized per component mask and compiled, the
//! override shaders, and the per-instance shading environments. It must not trace or shade.

use super::error::RenderError;
use super::stats::RenderStats;
use crate::geometry::{AttributeMap, resolve_attributes};
use crate::passes::{
    Components, KNOWN_COMPONENTS, OverrideKind, PassKind, RayMatch, RuleAction, action_for,
    program_mask,
};
use crate::scene::{Scene, Settings};
use crate::shader::{Shader, ShaderBackend};
use glam::DMat4;
use shadenet_graph::ir::{Program, Space, Stream};
use shadenet_graph::opt::{self, Needs, Specialization};
use shadenet_runtime::{ShadeEnv, Transform};
use std::sync::Arc;

/// One specialized program, compiled.
#[derive(Clone)]
pub(super) struct Specialized {
    pub(super) shader: Arc<dyn Shader>,
    /// The component mask it was specialized for (also given to the shading context).
    pub(super) mask: u32,
    /// Compute uv and tangents.
    pub(super) uv_tangents: bool,
    /// Compute ray differentials.
    pub(super) differentials: bool,
    /// Reads object space (then its environment's object transform matters, and hits of
    /// different instances cannot share a batch).
    pub(super) object_space: bool,
    /// The output parts the film reads.
    pub(super) parts: Vec<Part>,
    /// Per mesh (indexed like `Scene::meshes`), where each slot of the program's attribute
    /// table finds its values; empty when the program reads no attribute.
    pub(super) attributes: Arc<Vec<AttributeMap>>,
}

impl Specialized {
    pub(super) fn new(
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
            attributes: Arc::new(Vec::new()),
        })
    }
}

/// One output part the film reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Part {
    /// Scene component index, or `None` for an untagged (beauty-only) value.
    pub(super) comp: Option<usize>,
    /// First float in the shading call's output.
    pub(super) offset: usize,
    /// Floats.
    pub(super) width: usize,
    /// Whether it is part of the beauty (the first output).
    pub(super) beauty: bool,
}

/// What hits compute, per ray type and depth.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Action {
    /// Shade the material specialized to action number `usize`.
    Material(usize),
    /// An override shader.
    Override(OverrideKind),
}

/// The scene's render components: those the programs produce, then those the passes name
/// (an unknown name is an error; a known one no material has, a warning), then `emission`.
/// Returns them, the index of `emission` and the warnings.
pub(super) fn scene_components(
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
pub(super) fn action_table(s: &Settings) -> (Vec<(RuleAction, u32)>, Vec<Vec<Action>>) {
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
pub(super) fn compile_materials(
    scene: &Scene,
    programs: &[Program],
    actions: &[(RuleAction, u32)],
    backend: &dyn ShaderBackend,
    components: &Components,
    stats: &mut RenderStats,
    differentials: &mut bool,
) -> Result<(Vec<Vec<Specialized>>, Vec<String>), RenderError> {
    let mut shaders = Vec::new();
    let mut warnings = Vec::new();
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
            let mut sp = Specialized::new(&p, mask, &report.needs, backend, components, &m.name)?;
            sp.attributes = Arc::new(resolve_attributes(
                &p.attributes,
                &report.needs.attributes,
                &scene.meshes,
                &scene.mesh_names,
                &m.name,
                &mut warnings,
            ));
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
    Ok((shaders, warnings))
}

/// The override shaders the passes and the rules use, compiled.
pub(super) fn compile_overrides(
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
pub(super) fn shade_envs(scene: &Scene, lights: &[shadenet_runtime::Light]) -> Vec<ShadeEnv> {
    let cam_t = Transform::look_at(
        scene.camera.position.to_array(),
        scene.camera.look_at.to_array(),
        scene.camera.up.to_array(),
    )
    .unwrap_or(Transform::IDENTITY);
    let base = ShadeEnv {
        camera: cam_t,
        lights: lights.to_vec(),
        ..ShadeEnv::default()
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

pub(super) fn row_major(m: DMat4) -> [f64; 16] {
    m.transpose().to_cols_array()
}
