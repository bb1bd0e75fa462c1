//! The texture system and the `file` node: decoding, sampling, path resolution, and clear
//! errors for missing files.

use shadenet::load_network;
use shadenet::shade::{grid_env, shade_grid};
use shadenet_graph::ir::TextureFile;
use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv, Texture};
use std::path::PathBuf;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shadenet-tex-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A 2×2 RGBA PNG: top row red, green; bottom row blue, white (alpha 255 except the white
/// texel, 0).
fn write_png(path: &std::path::Path) {
    let px: Vec<u8> = vec![
        255, 0, 0, 255, 0, 255, 0, 255, //
        0, 0, 255, 255, 255, 255, 255, 0,
    ];
    image::save_buffer(path, &px, 2, 2, image::ExtendedColorType::Rgba8).unwrap();
}

#[test]
fn texel_centres_and_srgb_decoding() {
    let d = dir("centres");
    let p = d.join("t.png");
    write_png(&p);
    let t = Texture::load(&TextureFile::auto(p.to_string_lossy())).unwrap();
    assert_eq!((t.width(), t.height()), (2, 2));
    // Texel centres: (0.25, 0.75) is the top-left texel (uv origin is the bottom-left).
    assert_eq!(t.sample([0.25f64, 0.75]), [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(t.sample([0.75f64, 0.75]), [0.0, 1.0, 0.0, 1.0]);
    assert_eq!(t.sample([0.25f64, 0.25]), [0.0, 0.0, 1.0, 1.0]);
    assert_eq!(t.sample([0.75f64, 0.25]), [1.0, 1.0, 1.0, 0.0]);
    // Half way between red and green: bilinear.
    assert_eq!(t.sample([0.5f64, 0.75]), [0.5, 0.5, 0.0, 1.0]);
    // Repeat wrapping: one period away is the same texel.
    assert_eq!(t.sample([1.25f64, -0.25]), t.sample([0.25f64, 0.75]));
    // Non-finite coordinates never panic.
    let nan = t.sample([f64::NAN, f64::INFINITY]);
    assert!(nan.iter().all(|c| c.is_finite()));
}

#[test]
fn srgb_mid_grey_decodes_to_linear() {
    let d = dir("grey");
    let p = d.join("g.png");
    image::save_buffer(&p, &[128u8, 128, 128], 1, 1, image::ExtendedColorType::Rgb8).unwrap();
    let t = Texture::load(&TextureFile::auto(p.to_string_lossy())).unwrap();
    let c = t.sample([0.5f64, 0.5]);
    let want = ((128.0 / 255.0 + 0.055) / 1.055f64).powf(2.4);
    assert!((c[0] - want).abs() < 1e-6, "{c:?} vs {want}");
    assert_eq!(c[3], 1.0);
}

#[test]
fn file_node_reads_relative_to_the_network_and_missing_files_are_named() {
    let d = dir("node");
    write_png(&d.join("tex.png"));
    let net = d.join("net.json");
    std::fs::write(
        &net,
        r#"{"nodes": [{"name": "img", "type": "file", "inputs": {"fileTextureName": "tex.png"}}],
            "outputs": {"color": "img.outColor", "alpha": "img.outAlpha"}}"#,
    )
    .unwrap();
    let c = load_network(&net).unwrap();
    assert_eq!(
        c.program.textures,
        vec![TextureFile::auto(d.join("tex.png").to_string_lossy())]
    );
    let interp = Interpreter::<f32>::new(&c.program).unwrap();
    let env = ShadeEnv::default();
    let frag = Fragment {
        uv: [0.75, 0.25],
        ..Fragment::default()
    };
    let out = interp.shade(&ShadeCtx::new(frag, &env));
    assert_eq!(out.values, vec![1.0, 1.0, 1.0, 0.0]);

    std::fs::remove_file(d.join("tex.png")).unwrap();
    let c = load_network(&net).unwrap();
    let err = Interpreter::<f32>::new(&c.program).unwrap_err().to_string();
    assert!(
        err.contains("cannot load texture") && err.contains("tex.png"),
        "{err}"
    );
    let env = grid_env(&[]);
    assert!(shade_grid::<f32>(&c.program, &env, 4, 4, u32::MAX).is_err());
}

#[test]
fn empty_file_name_is_a_link_error() {
    let src = r#"{"nodes": [{"name": "img", "type": "file"}], "outputs": {"c": "img.outColor"}}"#;
    let err = shadenet::compile_json(src, &shadenet::NodeLibrary::standard())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("node `img` (file)") && err.contains("fileTextureName"),
        "{err}"
    );
}

#[test]
fn the_test_texture_is_the_generator_s_output() {
    // examples/scenes/textures/grid.png is `shadenet gen texture`'s output, byte for byte.
    let committed = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/textures/grid.png"),
    )
    .unwrap();
    let generated = shadenet::generate::test_texture().unwrap();
    assert!(
        committed == generated,
        "regenerate it with `shadenet gen texture`"
    );
    let img = image::load_from_memory(&committed).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (2048, 2048));
    for (x, y) in [(0, 0), (1, 1), (17, 3), (300, 900), (2047, 2047), (1280, 5)] {
        assert_eq!(
            img.get_pixel(x, y).0,
            shadenet::generate::test_texel(x, y),
            "({x}, {y})"
        );
    }
}
