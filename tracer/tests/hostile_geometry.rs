//! Hostile geometry never reaches the BVH builder (issue 24), and geometry at the edge of
//! the supported coordinate range renders correctly.

use shadenet_graph::ir::{Builder, Program};
use shadenet_tracer::geometry::{MAX_COORDINATE, unit_quad};
use shadenet_tracer::render::{RenderError, Renderer};
use shadenet_tracer::scene;
use shadenet_tracer::shader::InterpBackend;
use std::path::Path;

/// A material whose color is a constant.
fn flat(rgb: [f64; 3]) -> Program {
    let mut b = Builder::new("flat");
    let c = b.color(rgb);
    b.output("color", None, c);
    b.finish().unwrap()
}

/// The programs in `[materials]` key order: `far` green, `near` red.
fn programs() -> Vec<Program> {
    vec![flat([0.0, 1.0, 0.0]), flat([1.0, 0.0, 0.0])]
}

const TWO_QUADS: &str = r#"
[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
fov = 0.01
resolution = [9, 9]

[materials.near]
json = '{"nodes": [], "outputs": {}}'
[materials.far]
json = '{"nodes": [], "outputs": {}}'

[meshes.q]
type = "quad"

[[instances]]
mesh = "q"
material = "near"
scale = 1e-4

[[instances]]
mesh = "q"
material = "far"
translate = [0, 0, -10]
"#;

/// A scene built by hand (not loaded, so not checked with its keys) with a transform that
/// takes a triangle beyond f32: obvhs 0.4 panicked on it (`distribute_left < 7` in debug,
/// an index of u32::MAX in `bvh2_to_cwbvh.rs` in release); now it is an error naming the
/// instance.
#[test]
fn a_hand_built_scene_beyond_the_range_is_an_error_not_a_panic() {
    for m in [
        glam::DMat4::from_scale(glam::DVec3::splat(1e20)),
        glam::DMat4::from_translation(glam::DVec3::new(0.0, 1e39, 0.0)),
    ] {
        let mut s = scene::parse(TWO_QUADS, Path::new("t.toml")).unwrap();
        s.instances[1].transform = m;
        let e = Renderer::new(s, programs(), &InterpBackend).expect_err("accepted");
        assert!(matches!(e, RenderError::Geometry { .. }), "{e}");
        assert!(
            e.to_string().starts_with("instance `q #1`: 2 triangle(s)"),
            "{e}"
        );
    }
}

/// The largest allowed scale beside tiny geometry: a quad reaching ±MAX_COORDINATE behind a
/// quad of half-size 1e-4. The BVH builds and rays find both: the centre pixels see the
/// tiny quad (red), the corners the huge one (green).
#[test]
fn the_largest_scale_beside_tiny_geometry_renders() {
    let text = TWO_QUADS.replace(
        "translate = [0, 0, -10]",
        &format!("translate = [0, 0, -10]\nscale = {MAX_COORDINATE:e}"),
    );
    let s = scene::parse(&text, Path::new("t.toml")).unwrap();
    let r = Renderer::new(s, programs(), &InterpBackend).unwrap();
    let (film, stats) = r.render(&|_, _| {});
    assert_eq!(stats.triangles, 4);
    let b = film.layer("beauty").unwrap();
    let px = |x: usize, y: usize| [0, 1, 2, 3].map(|c| b.at(y * 9 + x, c));
    assert_eq!(
        px(4, 4),
        [1.0, 0.0, 0.0, 1.0],
        "the centre sees the tiny quad"
    );
    for (x, y) in [(0, 0), (8, 0), (0, 8), (8, 8)] {
        assert_eq!(
            px(x, y),
            [0.0, 1.0, 0.0, 1.0],
            "corner ({x}, {y}) sees the huge quad"
        );
    }
}

/// Many triangles without area in one place made obvhs build a BVH deeper than its
/// traversal stack (a debug assertion; in release, hits silently lost); 10 000 of them
/// overflowed the thread's stack in its recursive cost pass. They cannot be hit, so the
/// BVH leaves them out.
#[test]
fn coincident_degenerate_triangles_are_left_out() {
    let mut s = scene::parse(TWO_QUADS, Path::new("t.toml")).unwrap();
    let mut mesh = unit_quad();
    let n = mesh.positions.len() as u32;
    mesh.positions.push([0.5, 0.5, 0.0]);
    mesh.triangles
        .extend(std::iter::repeat_n([n, n, n], 10_000));
    if let Some(v) = &mut mesh.normals {
        v.push([0.0, 0.0, 1.0]);
    }
    if let Some(v) = &mut mesh.uvs {
        v.push([0.5, 0.5]);
    }
    s.meshes[0] = mesh;
    let r = Renderer::new(s, programs(), &InterpBackend).unwrap();
    let (film, stats) = r.render(&|_, _| {});
    assert_eq!(stats.triangles, 4);
    assert_eq!(film.layer("beauty").unwrap().at(4 * 9 + 4, 0), 1.0);
}

/// A thousand instances of one quad under one transform: a thousand coincident boxes made
/// obvhs build a tree deeper than its traversal stack (a debug assertion; in release, hits
/// silently lost). Exact copies are left out of the BVH, the first placed kept: the quad
/// renders, every pixel that sees it sees it in the first instance's material.
#[test]
fn a_thousand_copies_of_one_quad_render() {
    let mut text = TWO_QUADS.to_string();
    for _ in 0..1000 {
        text.push_str("\n[[instances]]\nmesh = \"q\"\nmaterial = \"far\"\nscale = 1e-4\n");
    }
    let s = scene::parse(&text, Path::new("t.toml")).unwrap();
    let r = Renderer::new(s, programs(), &InterpBackend).unwrap();
    let (film, stats) = r.render(&|_, _| {});
    assert_eq!(stats.triangles, 4, "one copy of each quad's triangles");
    let b = film.layer("beauty").unwrap();
    assert_eq!(
        [0, 1, 2, 3].map(|c| b.at(4 * 9 + 4, c)),
        [1.0, 0.0, 0.0, 1.0],
        "the centre sees the tiny quad in the first instance's material (red)"
    );
}
