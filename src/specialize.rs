//! Per-object material specialization: a MaterialX material whose string-valued
//! `geompropvalueuniform` nodes read uniform geometric properties (a texture's file name per
//! object, say) is compiled once per distinct set of those values among the instances bound
//! to it. Strings are compile-time values (they never reach the IR), so each compile folds
//! its instances' values in; instances that agree share one compile.
//!
//! This module owns the grouping and the rebinding of instances; it must not compile
//! (`render::compile_material` does, and says which properties a document reads) nor
//! interpret MaterialX.

use shadenet_tracer::scene::{MaterialRef, Scene};
use std::collections::{BTreeMap, BTreeSet};

/// Splits each material of `scene` whose document reads uniform geometric properties
/// (`read[material]`, from compiling it as the scene names it) into one material per
/// distinct set of its instances' values, each named `material{name=value, …}`: the first
/// set takes the material's place, the others are appended and their instances rebound.
/// A property an instance does not give is left out of its set (the node's default).
///
/// Returns, for each material of the scene after the split, where its compile comes from:
/// `Some(m)`, the compile of material `m` as the scene named it (the material itself, or a
/// set that gives no values), or `None`, a compile of its own.
pub fn by_geomprops(scene: &mut Scene, read: &[BTreeSet<String>]) -> Vec<Option<usize>> {
    let mut from: Vec<Option<usize>> = (0..scene.materials.len()).map(Some).collect();
    for (mi, read) in read.iter().enumerate() {
        if read.is_empty() {
            continue;
        }
        let base = scene.materials[mi].clone();
        let mut variants: Vec<BTreeMap<String, String>> = Vec::new();
        for inst in scene.instances.iter_mut().filter(|i| i.material == mi) {
            let values = values_read(&inst.geomprops, read);
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
            let source = values.is_empty().then_some(mi);
            let v = MaterialRef {
                name: variant_name(&base.name, &values),
                geomprops: values,
                ..base.clone()
            };
            if k == 0 {
                scene.materials[mi] = v;
                from[mi] = source;
            } else {
                scene.materials.push(v);
                from.push(source);
            }
        }
    }
    from
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
