//! The glTF loader: triangle meshes of the default scene with node transforms applied, every
//! external buffer through the input gate first.

use super::{Mesh, VertexAttribute};
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
    // Named attributes, with the number of primitives that had each.
    let mut attributes: Vec<(VertexAttribute, usize)> = Vec::new();
    let mut prims = 0;
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
            let attrs = read_attributes(&prim, &buffers, &m)?;
            merge_attributes(&mut attributes, attrs, out.positions.len(), n, prims);
            prims += 1;
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
    // An attribute some primitive lacks (or has with another width) is dropped: a mesh's
    // attributes cover every vertex.
    out.attributes = attributes
        .into_iter()
        .filter(|(_, k)| *k == prims)
        .map(|(a, _)| a)
        .collect();
    out.normals = normals_ok.then_some(normals_all);
    out.uvs = uvs_ok.then_some(uvs_all);
    out.check()
}

/// The named attributes of a primitive (docs/scene-format.md, "Vertex attributes"):
/// `COLOR_n` (RGB or RGBA as stored, normalized integers to [0, 1]), `TEXCOORD_n` for n ≥ 1
/// (v flipped as for uv), `TANGENT` (xyz through the node transform, w the handedness) and
/// custom `_NAME` attributes (float accessors of 1 to 4 components, as stored).
fn read_attributes(
    prim: &gltf::Primitive,
    buffers: &[gltf::buffer::Data],
    m: &DMat4,
) -> Result<Vec<VertexAttribute>, String> {
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let attr = |name: String, components: usize, values: Vec<f32>| VertexAttribute {
        name,
        components,
        values,
    };
    let mut out = Vec::new();
    for (semantic, accessor) in prim.attributes() {
        use gltf::Semantic as S;
        match semantic {
            S::Colors(set) => {
                let Some(c) = reader.read_colors(set) else {
                    continue;
                };
                let name = format!("COLOR_{set}");
                out.push(match c {
                    gltf::mesh::util::ReadColors::RgbF32(_)
                    | gltf::mesh::util::ReadColors::RgbU8(_)
                    | gltf::mesh::util::ReadColors::RgbU16(_) => {
                        attr(name, 3, c.into_rgb_f32().flatten().collect())
                    }
                    _ => attr(name, 4, c.into_rgba_f32().flatten().collect()),
                });
            }
            S::TexCoords(set) if set > 0 => {
                let Some(t) = reader.read_tex_coords(set) else {
                    continue;
                };
                let values = t.into_f32().flat_map(|[u, v]| [u, 1.0 - v]).collect();
                out.push(attr(format!("TEXCOORD_{set}"), 2, values));
            }
            S::Tangents => {
                let Some(t) = reader.read_tangents() else {
                    continue;
                };
                let values = t
                    .flat_map(|[x, y, z, w]| {
                        let v = m.transform_vector3(DVec3::new(x.into(), y.into(), z.into()));
                        let [x, y, z] = v.normalize_or_zero().as_vec3().to_array();
                        [x, y, z, w]
                    })
                    .collect();
                out.push(attr("TANGENT".into(), 4, values));
            }
            S::Extras(name) => {
                let name = format!("_{name}");
                let (values, components) = read_floats(&accessor, buffers)
                    .map_err(|e| format!("attribute `{name}`: {e}"))?;
                out.push(attr(name, components, values));
            }
            _ => {}
        }
    }
    Ok(out)
}

/// A float accessor's values (1 to 4 components), flattened.
fn read_floats(
    accessor: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
) -> Result<(Vec<f32>, usize), String> {
    use gltf::accessor::{DataType, Dimensions, Iter};
    if accessor.data_type() != DataType::F32 || accessor.normalized() {
        return Err("only float accessors are read as attributes".into());
    }
    let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| &d.0[..]);
    let missing = || "its accessor has no readable data".to_string();
    Ok(match accessor.dimensions() {
        Dimensions::Scalar => (
            Iter::<f32>::new(accessor.clone(), get)
                .ok_or_else(missing)?
                .collect(),
            1,
        ),
        Dimensions::Vec2 => (
            flat(Iter::<[f32; 2]>::new(accessor.clone(), get).ok_or_else(missing)?),
            2,
        ),
        Dimensions::Vec3 => (
            flat(Iter::<[f32; 3]>::new(accessor.clone(), get).ok_or_else(missing)?),
            3,
        ),
        Dimensions::Vec4 => (
            flat(Iter::<[f32; 4]>::new(accessor.clone(), get).ok_or_else(missing)?),
            4,
        ),
        d => {
            return Err(format!(
                "a {d:?} accessor is not a vertex attribute (1 to 4 floats)"
            ));
        }
    })
}

fn flat<const N: usize>(it: impl Iterator<Item = [f32; N]>) -> Vec<f32> {
    it.flatten().collect()
}

/// Appends one primitive's attributes (`n` vertices, the mesh having `before` so far, after
/// `prims` primitives) to the mesh's: an attribute seen for the first time counts only if
/// no primitive came before; one with another width than before is not counted (dropped
/// at the end).
fn merge_attributes(
    all: &mut Vec<(VertexAttribute, usize)>,
    attrs: Vec<VertexAttribute>,
    before: usize,
    n: usize,
    prims: usize,
) {
    for a in attrs {
        if a.values.len() != n * a.components {
            continue;
        }
        match all.iter_mut().find(|(b, _)| b.name == a.name) {
            Some((b, k)) if b.components == a.components && *k == prims => {
                b.values.extend(a.values);
                *k += 1;
            }
            Some(_) => {}
            None if prims == 0 && before == 0 => all.push((a, 1)),
            None => {}
        }
    }
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

    /// A triangle with named attributes, every buffer written by the test: `COLOR_0`
    /// (RGBA floats), `TEXCOORD_1`, `TANGENT` and a custom `_TEMP` (scalar) are read with
    /// their widths; a non-finite value is an error naming the attribute and vertex.
    #[test]
    fn gltf_named_attributes_are_read() {
        let dir = std::env::temp_dir().join(format!("shadenet-gltf-attrs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let write = |temp: [f32; 3]| {
            let mut f: Vec<f32> = vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]; // 0: 36 B
            f.extend([1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.5, 0.0, 0.0, 1.0, 0.25]); // 36: 48 B
            f.extend([0.0, 0.0, 1.0, 0.0, 0.0, 1.0]); // 84: 24 B
            f.extend([1.0, 0.0, 0.0, -1.0].repeat(3)); // 108: 48 B
            f.extend(temp); // 156: 12 B
            let bytes: Vec<u8> = f.iter().flat_map(|x| x.to_le_bytes()).collect();
            std::fs::write(dir.join("attrs.bin"), &bytes).unwrap();
            let view = |off: usize, len: usize| {
                format!(r#"{{ "buffer": 0, "byteOffset": {off}, "byteLength": {len} }}"#)
            };
            let acc = |v: usize, ty: &str| {
                format!(
                    r#"{{ "bufferView": {v}, "componentType": 5126, "count": 3, "type": "{ty}" }}"#
                )
            };
            let json = format!(
                r#"{{ "asset": {{ "version": "2.0" }},
  "buffers": [ {{ "byteLength": 168, "uri": "attrs.bin" }} ],
  "bufferViews": [ {}, {}, {}, {}, {} ],
  "accessors": [ {{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0] }}, {}, {}, {}, {} ],
  "meshes": [ {{ "primitives": [ {{ "attributes": {{ "POSITION": 0, "COLOR_0": 1,
     "TEXCOORD_1": 2, "TANGENT": 3, "_TEMP": 4 }} }} ] }} ],
  "nodes": [ {{ "mesh": 0 }} ], "scenes": [ {{ "nodes": [0] }} ], "scene": 0 }}"#,
                view(0, 36),
                view(36, 48),
                view(84, 24),
                view(108, 48),
                view(156, 12),
                acc(1, "VEC4"),
                acc(2, "VEC2"),
                acc(3, "VEC4"),
                acc(4, "SCALAR"),
            );
            let p = dir.join("attrs.gltf");
            std::fs::write(&p, json).unwrap();
            p
        };
        let m = load_gltf(&write([10.0, 20.0, 30.0])).unwrap();
        let names: Vec<(&str, usize)> = m
            .attributes
            .iter()
            .map(|a| (a.name.as_str(), a.components))
            .collect();
        for want in [
            ("COLOR_0", 4),
            ("TEXCOORD_1", 2),
            ("TANGENT", 4),
            ("_TEMP", 1),
        ] {
            assert!(names.contains(&want), "{want:?} in {names:?}");
        }
        let get = |n: &str| m.attributes.iter().find(|a| a.name == n).unwrap();
        assert_eq!(get("COLOR_0").at(2), [0.0, 0.0, 1.0, 0.25]);
        assert_eq!(get("TEXCOORD_1").at(1), [1.0, 1.0], "v flipped as uv is");
        assert_eq!(get("TANGENT").at(0), [1.0, 0.0, 0.0, -1.0]);
        assert_eq!(get("_TEMP").values, [10.0, 20.0, 30.0]);
        let e = load_gltf(&write([10.0, f32::NAN, 30.0])).unwrap_err();
        assert!(
            e.contains("attribute `_TEMP`: component 0 of vertex 1 is not finite"),
            "{e}"
        );
    }
}
