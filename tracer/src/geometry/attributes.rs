//! Named vertex attributes at render time: a program's attribute table resolved against
//! each mesh once (names compared here, never per hit), and the value of one at a hit,
//! interpolated with the hit's barycentrics by [`super::interpolate`] (the function uv and
//! normals go through).
//!
//! Widths: an attribute of as many components as the type read gives them all; a
//! four-component attribute read as a three-component type gives its first three (RGB of
//! RGBA, xyz of a glTF `TANGENT`); a three-component one read as a four-component type gets
//! a fourth of 1 (an RGB colour set read as color4: opaque). Any other pairing is resolved
//! to nothing (the shader's default) with a warning naming the material, attribute and mesh.

use super::{Mesh, VertexAttribute, interpolate};
use shadenet_graph::ir::AttributeDecl;

/// Per slot of a program's attribute table: the index of the mesh attribute it reads, or
/// `None` (the shader's default).
pub type AttributeMap = Vec<Option<u32>>;

/// Whether an attribute of `components` floats can be read as `width` floats.
fn readable(components: usize, width: usize) -> bool {
    components == width || (components == 4 && width == 3) || (components == 3 && width == 4)
}

/// For each mesh (indexed like `meshes`), where each slot of `decls` finds its values.
/// Only the slots `live` lists (what the specialized program still reads) are resolved;
/// a live slot whose attribute has a width that cannot be read as its type adds a warning
/// (naming `material`, the attribute and the mesh, from `mesh_names`).
pub fn resolve_attributes(
    decls: &[AttributeDecl],
    live: &[AttributeDecl],
    meshes: &[Mesh],
    mesh_names: &[String],
    material: &str,
    warnings: &mut Vec<String>,
) -> Vec<AttributeMap> {
    if live.is_empty() {
        return Vec::new();
    }
    meshes
        .iter()
        .enumerate()
        .map(|(mi, mesh)| {
            decls
                .iter()
                .map(|d| {
                    if !live.contains(d) {
                        return None;
                    }
                    let width = d.ty.width();
                    let i = mesh.attributes.iter().position(|a| a.name == d.name)?;
                    let a = &mesh.attributes[i];
                    if readable(a.components, width) {
                        return Some(i as u32);
                    }
                    let mesh_name = mesh_names.get(mi).map_or("?", String::as_str);
                    warnings.push(format!(
                        "material `{material}` reads attribute `{}` as a {} (width {width}), \
                         but mesh `{mesh_name}` has it with {} components: the material's \
                         default is used there",
                        d.name, d.ty, a.components
                    ));
                    None
                })
                .collect()
        })
        .collect()
}

/// The value of `a` at a hit on the triangle with vertices `verts` and barycentrics `bary`,
/// into `out` (1 to 4 floats; see the module documentation for the widths).
pub fn attribute_at(a: &VertexAttribute, verts: [u32; 3], bary: [f32; 3], out: &mut [f32]) {
    let corner = |k: usize| -> [f32; 4] {
        let v = a.at(verts[k] as usize);
        std::array::from_fn(|c| v.get(c).copied().unwrap_or(1.0))
    };
    let value = interpolate([corner(0), corner(1), corner(2)], bary);
    for (o, x) in out.iter_mut().zip(value) {
        *o = x;
    }
    for o in out.iter_mut().skip(a.components) {
        *o = 1.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shadenet_graph::types::Type;

    fn attr(name: &str, components: usize, values: Vec<f32>) -> VertexAttribute {
        VertexAttribute {
            name: name.into(),
            components,
            values,
        }
    }

    /// The value at known barycentrics is the weighted sum of the corners, bit for bit
    /// as `interpolate` computes it; widths 3 → 4 get an exact alpha of 1, 4 → 3 drop w.
    #[test]
    fn attributes_interpolate_at_known_barycentrics() {
        let a = attr(
            "COLOR_0",
            3,
            vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.5, 0.5],
        );
        let bary = [0.2, 0.3, 0.5];
        let mut out = [0.0f32; 3];
        attribute_at(&a, [0, 1, 2], bary, &mut out);
        assert_eq!(out, [0.2, 0.3, 0.5]);
        attribute_at(&a, [3, 3, 0], bary, &mut out);
        let want = 0.5f32 * 0.2 + 0.5 * 0.3 + 1.0 * 0.5;
        assert_eq!(out, [want, 0.5 * 0.2 + 0.5 * 0.3, 0.5 * 0.2 + 0.5 * 0.3]);
        let mut four = [0.0f32; 4];
        attribute_at(&a, [0, 1, 2], [0.1, 0.7, 0.2], &mut four);
        assert_eq!(four[3], 1.0, "an RGB set read as color4 is opaque");
        let t = attr("TANGENT", 4, [1.0, 0.0, 0.0, -1.0].repeat(3));
        let mut xyz = [0.0f32; 3];
        attribute_at(&t, [0, 1, 2], bary, &mut xyz);
        assert_eq!(xyz, [1.0, 0.0, 0.0]);
    }

    /// Names resolve once per mesh; a width that cannot be read gives no slot and a
    /// warning; dead slots are not resolved.
    #[test]
    fn slots_resolve_per_mesh_with_warnings_for_bad_widths() {
        let mesh = Mesh {
            attributes: vec![
                attr("COLOR_0", 4, vec![0.0; 12]),
                attr("_w", 2, vec![0.0; 6]),
            ],
            ..Mesh::default()
        };
        let decl = |name: &str, ty| AttributeDecl {
            name: name.into(),
            ty,
        };
        let decls = [
            decl("COLOR_0", Type::Color),
            decl("_w", Type::Float),
            decl("missing", Type::Vec3),
            decl("COLOR_0", Type::Vec2),
        ];
        let live = &decls[..3];
        let mut warnings = Vec::new();
        let names = ["tri".to_string(), "empty".to_string()];
        let maps = resolve_attributes(
            &decls,
            live,
            &[mesh, Mesh::default()],
            &names,
            "m",
            &mut warnings,
        );
        assert_eq!(maps, [vec![Some(0), None, None, None], vec![None; 4]]);
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(
            warnings[0].contains(
                "attribute `_w` as a float (width 1), but mesh `tri` has it with 2 components"
            ),
            "{}",
            warnings[0]
        );
        let none = resolve_attributes(&decls, &[], &[Mesh::default()], &names, "m", &mut warnings);
        assert!(
            none.is_empty(),
            "a program that reads no attribute resolves nothing"
        );
    }
}
