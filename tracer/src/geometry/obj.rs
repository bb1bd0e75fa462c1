//! The Wavefront OBJ loader: `tobj` parses; this file checks the face indices first (tobj 4
//! overflows on out-of-range relative indices) and gathers the models into one mesh.

use super::{Mesh, VertexAttribute};
use shadenet_runtime::input::{self, FileKind};
use std::path::Path;

/// The attribute name of an OBJ file's vertex colours (`v x y z r g b`): glTF's name of
/// the first colour set, which MaterialX `geomcolor` index 0 reads.
pub const OBJ_COLOR_NAME: &str = "COLOR_0";

/// Loads every object of a Wavefront OBJ file (triangulated; normals, uv and vertex colours
/// (`v x y z r g b`, as attribute [`OBJ_COLOR_NAME`]) when every vertex has them).
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
    check_face_indices(&bytes)?;
    let (models, _materials) = tobj::load_obj_buf(&mut &bytes[..], &opts, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| e.to_string())?;
    let mut out = Mesh::default();
    let mut all_normals = true;
    let mut all_uvs = true;
    let mut all_colors = true;
    for m in &models {
        let nv = m.mesh.positions.len() / 3;
        all_normals &= m.mesh.normals.len() == nv * 3;
        all_uvs &= m.mesh.texcoords.len() == nv * 2;
        all_colors &= m.mesh.vertex_color.len() == nv * 3;
    }
    let mut colors = Vec::new();
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
        if all_colors {
            colors.extend(&mesh.vertex_color);
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
    // The `v x y z r g b` extension: the mesh's first colour set.
    if all_colors {
        out.attributes.push(VertexAttribute {
            name: OBJ_COLOR_NAME.into(),
            components: 3,
            values: colors,
        });
    }
    out.check()
}

/// What a face index refers to, in the order of a `v/vt/vn` triple.
const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];

/// Checks every index of every `f` and `l` line before tobj sees it: an index is 1-based,
/// counts back from the last element so far when negative, and must name an element the
/// file defines. tobj 4.0 does not check this itself: a relative index before the first
/// element wraps to a huge `usize` and overflows its arithmetic (a panic in debug builds, a
/// wrong element in release); index 0 silently reads as "no texture coordinate".
fn check_face_indices(bytes: &[u8]) -> Result<(), String> {
    let lines = || bytes.split(|&b| b == b'\n').map(<[u8]>::trim_ascii);
    let keyword = |line: &[u8]| -> Option<usize> {
        match line.split(u8::is_ascii_whitespace).next()? {
            b"v" => Some(0),
            b"vt" => Some(1),
            b"vn" => Some(2),
            _ => None,
        }
    };
    let mut total = [0i64; 3];
    for line in lines() {
        if let Some(k) = keyword(line) {
            total[k] += 1;
        }
    }
    let mut so_far = [0i64; 3];
    for (n, line) in lines().enumerate() {
        if let Some(k) = keyword(line) {
            so_far[k] += 1;
            continue;
        }
        let mut words = line
            .split(u8::is_ascii_whitespace)
            .filter(|w| !w.is_empty());
        if !matches!(words.next(), Some(b"f" | b"l")) {
            continue;
        }
        for word in words {
            for (k, part) in word.split(|&b| b == b'/').enumerate().take(3) {
                if part.is_empty() {
                    continue;
                }
                let at = |what: String| {
                    format!(
                        "line {}: `{}`: {what}",
                        n + 1,
                        String::from_utf8_lossy(word)
                    )
                };
                let i: i64 = std::str::from_utf8(part)
                    .ok()
                    .and_then(|p| p.parse().ok())
                    .ok_or_else(|| at(format!("{} index is not an integer", KINDS[k])))?;
                let ok = match i {
                    0 => false,
                    i if i > 0 => i <= total[k],
                    i => so_far[k] + i >= 0,
                };
                if !ok {
                    return Err(at(format!(
                        "{} index {i} is out of range ({} defined so far, {} in the file; indices start at 1, negative ones count back from the last)",
                        KINDS[k], so_far[k], total[k]
                    )));
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
        // Face indices out of range, each way: a clear error naming the line, never a panic
        // inside tobj (the fuzzer's finding: `2/-12/1` with four texture coordinates).
        let quad = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 1\n";
        for (face, says) in [
            (
                "f 1/1/1 2/-12/1 3/3/1",
                "line 8: `2/-12/1`: texture coordinate index -12 is out of range (3 defined so far",
            ),
            ("f 1 2 4", "line 8: `4`: vertex index 4 is out of range"),
            ("f 0 1 2", "line 8: `0`: vertex index 0 is out of range"),
            ("f 1/0 2/1 3/2", "line 8: `1/0`: texture coordinate index 0"),
            (
                "f 1//2 2//1 3//1",
                "line 8: `1//2`: normal index 2 is out of range",
            ),
            (
                "f -4 -2 -1",
                "line 8: `-4`: vertex index -4 is out of range",
            ),
            ("f 1 2 x", "line 8: `x`: vertex index is not an integer"),
            (
                "f 1 2 99999999999999999999",
                "vertex index is not an integer",
            ),
        ] {
            std::fs::write(&bad, format!("{quad}{face}\n")).unwrap();
            let e = load_obj(&bad).unwrap_err();
            assert!(e.starts_with(says) || e.contains(says), "{face}: {e}");
        }
        // Relative indices in range are fine.
        std::fs::write(&bad, format!("{quad}f -3/-3/-1 -2/-2/-1 -1/-1/-1\n")).unwrap();
        assert_eq!(load_obj(&bad).unwrap().triangles.len(), 1);
    }

    /// `v x y z r g b` gives attribute `COLOR_0` (3 components per vertex); a NaN colour is
    /// an error naming the attribute and vertex; files without colours have no attributes.
    #[test]
    fn obj_vertex_colours_become_color_0() {
        let dir = std::env::temp_dir().join(format!("shadenet-obj-vc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("vc.obj");
        std::fs::write(&p, "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n").unwrap();
        let m = load_obj(&p).unwrap();
        assert_eq!(m.attributes.len(), 1);
        let a = &m.attributes[0];
        assert_eq!((a.name.as_str(), a.components), (OBJ_COLOR_NAME, 3));
        assert_eq!(a.values, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        std::fs::write(
            &p,
            "v 0 0 0 1 0 0\nv 1 0 0 nan 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n",
        )
        .unwrap();
        let e = load_obj(&p).unwrap_err();
        assert!(
            e.contains("attribute `COLOR_0`: component 0 of vertex 1 is not finite"),
            "{e}"
        );
        std::fs::write(&p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert!(load_obj(&p).unwrap().attributes.is_empty());
    }
}
