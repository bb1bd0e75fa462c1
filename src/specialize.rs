//! Per-object material specialization: a MaterialX material whose string-valued
//! `geompropvalueuniform` nodes read uniform geometric properties (a texture's file name per
//! object, say) is compiled once per distinct set of those values among the instances bound
//! to it. Strings are compile-time values (they never reach the IR), so each compile folds
//! its instances' values in; instances that agree share one compile.
//!
//! This module owns the grouping and the rebinding of instances; it must not compile
//! (`render::compile_material` does) nor interpret MaterialX (`graph::mtlx` names the
//! properties a document reads).

use shadenet_graph::error_chain;
use shadenet_graph::mtlx::Selection;
use shadenet_tracer::scene::{MaterialRef, MaterialSource, Scene};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A material whose document could not be read to learn the properties it reads.
#[derive(Debug, thiserror::Error)]
#[error("material `{material}` ({source_name}): {message}")]
pub struct SpecializeError {
    /// The material's key.
    pub material: String,
    /// Its document.
    pub source_name: String,
    /// What is wrong.
    pub message: String,
}

/// Splits each MaterialX material of `scene` that reads uniform geometric properties into
/// one material per distinct set of its instances' values, each named
/// `material{name=value, …}`: the first set takes the material's place, the others are
/// appended and their instances rebound.
/// A property an instance does not give is left out of its set (the node's default).
pub fn by_geomprops(
    scene: &mut Scene,
    mtlx_libraries: Option<&Path>,
) -> Result<(), SpecializeError> {
    for mi in 0..scene.materials.len() {
        let m = &scene.materials[mi];
        let MaterialSource::Mtlx {
            file,
            material,
            output,
        } = &m.source
        else {
            continue;
        };
        let sel = Selection {
            material: material.clone(),
            output: output.clone(),
            ..Default::default()
        };
        let read = crate::mtlx::mtlx_geomprops(file, mtlx_libraries, &sel).map_err(|e| {
            SpecializeError {
                material: m.name.clone(),
                source_name: file.display().to_string(),
                message: error_chain(&e),
            }
        })?;
        if read.is_empty() {
            continue;
        }
        let base = scene.materials[mi].clone();
        let mut variants: Vec<BTreeMap<String, String>> = Vec::new();
        for inst in scene.instances.iter_mut().filter(|i| i.material == mi) {
            let values = values_read(&inst.geomprops, &read);
            let k = match variants.iter().position(|v| *v == values) {
                Some(k) => k,
                None => {
                    variants.push(values);
                    variants.len() - 1
                }
            };
            if k > 0 {
                inst.material = scene.materials.len() + k - 1;
            }
        }
        for (k, values) in variants.into_iter().enumerate() {
            let v = MaterialRef {
                name: variant_name(&base.name, &values),
                geomprops: values,
                ..base.clone()
            };
            if k == 0 {
                scene.materials[mi] = v;
            } else {
                scene.materials.push(v);
            }
        }
    }
    Ok(())
}

/// The instance's values of the properties a material reads.
fn values_read(
    given: &BTreeMap<String, String>,
    read: &BTreeSet<String>,
) -> BTreeMap<String, String> {
    given
        .iter()
        .filter(|(k, _)| read.contains(*k))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect()
}

/// `name{prop=value, …}`: a specialized material's name in messages and statistics.
fn variant_name(name: &str, values: &BTreeMap<String, String>) -> String {
    let list: Vec<String> = values.iter().map(|(k, v)| format!("{k}={v}")).collect();
    format!("{name}{{{}}}", list.join(", "))
}
