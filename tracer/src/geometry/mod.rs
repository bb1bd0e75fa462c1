//! Meshes in object space: the built-in shapes here, the OBJ and glTF loaders in their own
//! files (they own the checks of their formats; the mesh type and its `check` are shared).
//!
//! Every shape is triangles. Spheres are **tessellated** (a latitude–longitude grid with
//! smooth vertex normals and the sphere's own `uv`), not analytic: one primitive type keeps
//! the BVH, the watertight test and the offsets uniform; `segments` sets the accuracy.
//! Winding is counter-clockwise seen from the front, so `(p1 − p0) × (p2 − p0)` is the
//! outward geometric normal of the built-in shapes.

use glam::Vec3;
use shadenet_graph::ops::math;

mod attributes;
mod gltf_scene;
mod obj;

pub use attributes::{AttributeMap, attribute_at, resolve_attributes};
pub use gltf_scene::load_gltf;
pub use obj::load_obj;

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
    /// Named per-vertex attributes (primvars) beyond normals and uv: what
    /// `Op::Attribute` reads, interpolated at the hit like uv. The built-in shapes have
    /// none.
    pub attributes: Vec<VertexAttribute>,
}

/// One named per-vertex attribute of a mesh (see `docs/scene-format.md`, "Vertex
/// attributes", for the names the loaders give).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexAttribute {
    /// The name shaders ask for (`COLOR_0`, `TEXCOORD_1`, `TANGENT`, `_NAME` …).
    pub name: String,
    /// Floats per vertex, 1 to 4.
    pub components: usize,
    /// `components` floats per vertex, vertex after vertex.
    pub values: Vec<f32>,
}

impl VertexAttribute {
    /// The value at vertex `i` (its `components` floats).
    pub fn at(&self, i: usize) -> &[f32] {
        &self.values[i * self.components..(i + 1) * self.components]
    }
}

/// `a·b0 + b·b1 + c·b2`, component by component: the one barycentric interpolation of
/// vertex data (positions, normals, uv and named attributes alike).
pub fn interpolate<const N: usize>(v: [[f32; N]; 3], bary: [f32; 3]) -> [f32; N] {
    std::array::from_fn(|k| v[0][k] * bary[0] + v[1][k] * bary[1] + v[2][k] * bary[2])
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
        for a in &self.attributes {
            check_attribute(a, n)?;
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

/// An attribute's width, length and values: 1 to 4 finite floats per vertex.
fn check_attribute(a: &VertexAttribute, vertices: usize) -> Result<(), String> {
    let name = &a.name;
    if !(1..=4).contains(&a.components) {
        return Err(format!(
            "attribute `{name}` has {} components per vertex; 1 to 4 are supported",
            a.components
        ));
    }
    if a.values.len() != vertices * a.components {
        return Err(format!(
            "attribute `{name}` has {} values, not {} ({vertices} vertices × {})",
            a.values.len(),
            vertices * a.components,
            a.components
        ));
    }
    if let Some(i) = a.values.iter().position(|x| !x.is_finite()) {
        return Err(format!(
            "attribute `{name}`: component {} of vertex {} is not finite ({})",
            i % a.components,
            i / a.components,
            a.values[i]
        ));
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::*;

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
