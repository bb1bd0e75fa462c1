//! The glTF loader: triangle meshes of the default scene with node transforms applied, every
//! external buffer through the input gate first.

use super::Mesh;
use glam::{DMat4, DVec3, Mat4};
use shadenet_runtime::input::{self, FileKind};
use std::path::{Path, PathBuf};

/// Loads every triangle mesh of a glTF file's default scene (or its first), with node
/// transforms applied (images are not loaded: the tracer takes only geometry from glTF).
pub fn load_gltf(path: &Path) -> Result<Mesh, String> {
    if !path.exists() {
        return Err("no such file".into());
    }
    // Only the buffers: a missing or undecodable texture image must not stop the geometry.
    // The file and every external buffer pass the input gate first.
    let bytes =
        input::read(path, FileKind::Mesh, "mesh").map_err(|e| shadenet_graph::error_chain(&e))?;
    let gltf::Gltf {
        document: doc,
        blob,
    } = gltf::Gltf::from_slice(&bytes).map_err(|e| e.to_string())?;
    check_gltf_buffers(&doc, path)?;
    let buffers = gltf::import_buffers(&doc, path.parent(), blob).map_err(|e| e.to_string())?;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or("the file has no scene")?;
    let mut out = Mesh::default();
    let (mut normals_all, mut uvs_all) = (Vec::new(), Vec::new());
    let (mut normals_ok, mut uvs_ok) = (true, true);
    let mut stack: Vec<(gltf::Node, DMat4)> = scene.nodes().map(|n| (n, DMat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        let local = Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4();
        let m = parent * local;
        if !m.is_finite() {
            // A number beyond f32 in the file (gltf reads f32) or a product overflowing.
            return Err(format!(
                "node {}: its transform (with its parents') is not finite",
                node.index()
            ));
        }
        for child in node.children() {
            stack.push((child, m));
        }
        let Some(mesh) = node.mesh() else { continue };
        let normal_m = m.inverse().transpose();
        for prim in mesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let Some(pos) = reader.read_positions() else {
                continue;
            };
            let base = out.positions.len() as u32;
            let pos: Vec<[f32; 3]> = pos
                .map(|p| {
                    m.transform_point3(DVec3::from(p.map(f64::from)))
                        .as_vec3()
                        .to_array()
                })
                .collect();
            let n = pos.len();
            let normals: Vec<[f32; 3]> = match reader.read_normals() {
                Some(it) => it
                    .map(|v| {
                        normal_m
                            .transform_vector3(DVec3::from(v.map(f64::from)))
                            .normalize_or_zero()
                            .as_vec3()
                            .to_array()
                    })
                    .collect(),
                None => Vec::new(),
            };
            let uvs: Vec<[f32; 2]> = match reader.read_tex_coords(0) {
                // glTF's v runs downwards; ours (like OBJ's) upwards.
                Some(t) => t.into_f32().map(|[u, v]| [u, 1.0 - v]).collect(),
                None => Vec::new(),
            };
            out.positions.extend(&pos);
            normals_ok &= normals.len() == n;
            uvs_ok &= uvs.len() == n;
            normals_all.extend(normals);
            uvs_all.extend(uvs);
            let idx: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..n as u32).collect(),
            };
            // A mirroring transform flips the winding: keep the front counter-clockwise.
            let flip = m.determinant() < 0.0;
            out.triangles.extend(idx.chunks_exact(3).map(|c| {
                if flip {
                    [base + c[0], base + c[2], base + c[1]]
                } else {
                    [base + c[0], base + c[1], base + c[2]]
                }
            }));
        }
    }
    if out.triangles.is_empty() {
        return Err("the file has no triangle meshes".into());
    }
    out.normals = normals_ok.then_some(normals_all);
    out.uvs = uvs_ok.then_some(uvs_all);
    out.check()
}

/// Checks every external buffer of a glTF document with the input gate, resolving its URI
/// as `gltf::import_buffers` does (relative to the file, percent-decoded; `file:` URIs as
/// given). A relative URI that does not decode to UTF-8 is an error here: gltf 1.4 would
/// panic on it (`urlencoding::decode(uri).unwrap()`).
fn check_gltf_buffers(doc: &gltf::Document, path: &Path) -> Result<(), String> {
    let base = path.parent().unwrap_or(Path::new("."));
    for buffer in doc.buffers() {
        let gltf::buffer::Source::Uri(uri) = buffer.source() else {
            continue;
        };
        let file = if let Some(rest) = uri.strip_prefix("file://").or(uri.strip_prefix("file:")) {
            PathBuf::from(rest)
        } else if uri.contains(':') {
            continue; // data: URIs (inside the checked file) and schemes gltf rejects
        } else {
            let decoded = percent_decode(uri).ok_or_else(|| {
                format!(
                    "buffer {}: the URI `{uri}` is not valid percent-encoded UTF-8",
                    buffer.index()
                )
            })?;
            base.join(decoded)
        };
        input::check(&file, FileKind::Mesh, "glTF buffer").map_err(|e| {
            format!(
                "buffer {}: {}",
                buffer.index(),
                shadenet_graph::error_chain(&e)
            )
        })?;
    }
    Ok(())
}

/// `%XX` escapes decoded (a malformed one kept as written, as `urlencoding` does); `None`
/// when the result is not UTF-8.
fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let escape = b
            .get(i + 1..i + 3)
            .filter(|h| h.iter().all(u8::is_ascii_hexdigit))
            .and_then(|h| u8::from_str_radix(std::str::from_utf8(h).ok()?, 16).ok());
        if let (b'%', Some(x)) = (b[i], escape) {
            out.push(x);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_gltf(dir: &Path, node: &str) -> std::path::PathBuf {
        let pos: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let bytes: Vec<u8> = pos.iter().flat_map(|x| x.to_le_bytes()).collect();
        std::fs::write(dir.join("tri.bin"), &bytes).unwrap();
        let json = format!(
            r#"{{ "asset": {{ "version": "2.0" }},
  "buffers": [ {{ "byteLength": 36, "uri": "tri.bin" }} ],
  "bufferViews": [ {{ "buffer": 0, "byteOffset": 0, "byteLength": 36 }} ],
  "accessors": [ {{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0] }} ],
  "meshes": [ {{ "primitives": [ {{ "attributes": {{ "POSITION": 0 }} }} ] }} ],
  "nodes": [ {node} ],
  "scenes": [ {{ "nodes": [0] }} ],
  "scene": 0 }}"#
        );
        let p = dir.join("tri.gltf");
        std::fs::write(&p, json).unwrap();
        p
    }

    #[test]
    fn gltf_node_transforms_apply_and_mirrors_keep_the_winding() {
        let dir = std::env::temp_dir().join(format!("shadenet-gltf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = write_gltf(&dir, r#"{ "mesh": 0, "translation": [0, 0, -1] }"#);
        let m = load_gltf(&p).unwrap();
        assert_eq!(
            m.positions,
            [[0.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 1.0, -1.0]]
        );
        assert_eq!(m.triangles, [[0, 1, 2]]);
        assert!(m.normals.is_none() && m.uvs.is_none());
        let p = write_gltf(&dir, r#"{ "mesh": 0, "scale": [-1, 1, 1] }"#);
        let m = load_gltf(&p).unwrap();
        assert_eq!(m.positions[1], [-1.0, 0.0, 0.0]);
        // The mirrored triangle is re-wound so its front still faces +z.
        assert_eq!(m.triangles, [[0, 2, 1]]);
        let e = load_gltf(&dir.join("missing.gltf")).unwrap_err();
        assert!(e.contains("no such file"), "{e}");
    }
}
