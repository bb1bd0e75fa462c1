//! Meshes in object space: the built-in shapes and the OBJ and glTF loaders.
//!
//! Every shape is triangles. Spheres are **tessellated** (a latitude–longitude grid with
//! smooth vertex normals and the sphere's own `uv`), not analytic: one primitive type keeps
//! the BVH, the watertight test and the offsets uniform; `segments` sets the accuracy.
//! Winding is counter-clockwise seen from the front, so `(p1 − p0) × (p2 − p0)` is the
//! outward geometric normal of the built-in shapes.

use glam::{DMat4, DVec3, Mat4, Vec3};
use shadenet_graph::ops::math;
use shadenet_runtime::input::{self, FileKind};
use std::path::{Path, PathBuf};

/// The supported coordinate range: every vertex, in object space and after its instance's
/// transform, every camera point and every light position lies within ±this. It keeps the
/// BVH builder's f32 arithmetic finite (obvhs 0.4 panics on boxes whose surface areas
/// overflow: `docs/obvhs-defect.md`); `docs/scene-format.md` ("Coordinates") says how it
/// was chosen.
pub const MAX_COORDINATE: f64 = 1e13;

/// A triangle mesh in object space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<[f32; 3]>,
    /// Vertex normals (same length as `positions`), if the mesh has them.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Vertex texture coordinates, if the mesh has them.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Triangles, as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    fn push_quad(&mut self, corners: [[f32; 3]; 4], normal: [f32; 3]) {
        let base = self.positions.len() as u32;
        self.positions.extend(corners);
        if let Some(n) = &mut self.normals {
            n.extend([normal; 4]);
        }
        if let Some(uv) = &mut self.uvs {
            uv.extend([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        }
        self.triangles
            .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    }

    fn with_attributes() -> Mesh {
        Mesh {
            normals: Some(Vec::new()),
            uvs: Some(Vec::new()),
            ..Mesh::default()
        }
    }

    /// Checks indices and attribute lengths; drops nothing.
    fn check(self) -> Result<Mesh, String> {
        let n = self.positions.len();
        if let Some(bad) = self.triangles.iter().flatten().find(|&&i| i as usize >= n) {
            return Err(format!("vertex index {bad} out of range ({n} vertices)"));
        }
        if self.normals.as_ref().is_some_and(|v| v.len() != n)
            || self.uvs.as_ref().is_some_and(|v| v.len() != n)
        {
            return Err("attribute counts differ from the vertex count".into());
        }
        if self.positions.iter().flatten().any(|x| !x.is_finite()) {
            return Err("a vertex position is not finite".into());
        }
        if let Some(x) = self
            .positions
            .iter()
            .flatten()
            .find(|x| f64::from(x.abs()) > MAX_COORDINATE)
        {
            return Err(format!(
                "a vertex coordinate, {x:e}, is outside the supported range ±{MAX_COORDINATE:e}"
            ));
        }
        Ok(self)
    }
}

/// The square [−1, 1]² in the plane z = 0, facing +z, uv from (0, 0) at (−1, −1).
pub fn unit_quad() -> Mesh {
    let mut m = Mesh::with_attributes();
    m.push_quad(
        [
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ],
        [0.0, 0.0, 1.0],
    );
    m
}

/// The cube [−1, 1]³ with outward faces, each face its own [0, 1]² uv square.
pub fn unit_box() -> Mesh {
    let mut m = Mesh::with_attributes();
    // For each axis and sign: the normal, and two tangents t, b with t × b = normal.
    let faces: [([f32; 3], [f32; 3], [f32; 3]); 6] = [
        ([1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
        ([-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]),
        ([0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ];
    for (n, t, b) in faces {
        let (n, t, b) = (Vec3::from(n), Vec3::from(t), Vec3::from(b));
        let c = |s: f32, r: f32| (n + t * s + b * r).to_array();
        m.push_quad(
            [c(-1.0, -1.0), c(1.0, -1.0), c(1.0, 1.0), c(-1.0, 1.0)],
            n.to_array(),
        );
    }
    m
}

/// The unit sphere, `segments` around the equator and `segments / 2` rings, poles on ±y;
/// `u` runs around (from +x towards −z), `v` from the south pole (0) to the north (1).
pub fn unit_sphere(segments: u32) -> Mesh {
    let segments = segments.max(3);
    let rings = (segments / 2).max(2);
    let mut m = Mesh::with_attributes();
    for i in 0..=rings {
        let v = i as f64 / rings as f64;
        let theta = std::f64::consts::PI * (1.0 - v); // from the north pole
        for j in 0..=segments {
            let u = j as f64 / segments as f64;
            let phi = 2.0 * std::f64::consts::PI * u;
            let p = [
                (math::sin(theta) * math::cos(phi)) as f32,
                math::cos(theta) as f32,
                (-math::sin(theta) * math::sin(phi)) as f32,
            ];
            m.positions.push(p);
            if let Some(n) = &mut m.normals {
                n.push(p);
            }
            if let Some(uv) = &mut m.uvs {
                uv.push([u as f32, v as f32]);
            }
        }
    }
    let row = segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            let a = i * row + j;
            let (b, c, d) = (a + 1, a + row, a + row + 1);
            // Rows go south → north and columns towards −z: (a, b, d) is counter-clockwise
            // seen from outside.
            for t in [[a, b, d], [a, d, c]] {
                let p = |k: u32| Vec3::from(m.positions[k as usize]);
                let area = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
                if area.length_squared() > 0.0 {
                    m.triangles.push(t);
                }
            }
        }
    }
    m
}

/// Loads every object of a Wavefront OBJ file (triangulated; normals and uv when present).
pub fn load_obj(path: &Path) -> Result<Mesh, String> {
    if !path.exists() {
        return Err("no such file".into());
    }
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // Through the input gate: a regular file within the mesh limit, read bounded. Material
    // libraries are not read (the scene assigns materials), so a `mtllib` line cannot make
    // tobj open a device or a huge file either.
    let bytes =
        input::read(path, FileKind::Mesh, "mesh").map_err(|e| shadenet_graph::error_chain(&e))?;
    let (models, _materials) = tobj::load_obj_buf(&mut &bytes[..], &opts, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| e.to_string())?;
    let mut out = Mesh::default();
    let mut all_normals = true;
    let mut all_uvs = true;
    for m in &models {
        let nv = m.mesh.positions.len() / 3;
        all_normals &= m.mesh.normals.len() == nv * 3;
        all_uvs &= m.mesh.texcoords.len() == nv * 2;
    }
    if all_normals {
        out.normals = Some(Vec::new());
    }
    if all_uvs {
        out.uvs = Some(Vec::new());
    }
    for m in &models {
        let base = out.positions.len() as u32;
        let mesh = &m.mesh;
        out.positions
            .extend(mesh.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        if let Some(n) = &mut out.normals {
            n.extend(mesh.normals.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        }
        if let Some(uv) = &mut out.uvs {
            uv.extend(mesh.texcoords.chunks_exact(2).map(|c| [c[0], c[1]]));
        }
        out.triangles.extend(
            mesh.indices
                .chunks_exact(3)
                .map(|c| [base + c[0], base + c[1], base + c[2]]),
        );
    }
    if out.triangles.is_empty() {
        return Err("the file has no triangles".into());
    }
    out.check()
}

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

    #[test]
    fn obj_without_normals_or_uv_and_bad_files() {
        let dir = std::env::temp_dir().join(format!("shadenet-obj-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("quad.obj");
        std::fs::write(&p, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        let m = load_obj(&p).unwrap();
        assert_eq!(m.triangles.len(), 2, "the quad is triangulated");
        assert!(m.normals.is_none() && m.uvs.is_none());
        let bad = dir.join("bad.obj");
        std::fs::write(&bad, "v 0 0 0\nf 1 2 3\n").unwrap();
        assert!(load_obj(&bad).is_err());
    }

    #[test]
    fn built_in_shapes_face_outward() {
        for m in [unit_box(), unit_quad(), unit_sphere(12)] {
            for t in &m.triangles {
                let p = t.map(|i| Vec3::from(m.positions[i as usize]));
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                let vn = Vec3::from(m.normals.as_ref().unwrap()[t[0] as usize]);
                assert!(n.dot(vn) > 0.0, "{t:?}: winding against the vertex normal");
            }
        }
    }
}
