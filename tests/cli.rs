//! The `shadenet` binary: exit codes, messages, images, and no damage to existing files.

mod common;
use common::shadenet;

use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    common::tmp("cli", name)
}

#[test]
fn shade_writes_a_real_png_and_exr() {
    let png = tmp("marble.png");
    let exr = tmp("marble.exr");
    let (code, out, err) = shadenet(&[
        "shade",
        "examples/networks/marble.json",
        "-o",
        png.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--res",
        "64x48",
    ]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(out.contains("fragments/s"), "{out}");
    let img = image::open(&png).expect("png decodes").to_rgb8();
    assert_eq!(img.dimensions(), (64, 48));
    let distinct: std::collections::HashSet<_> = img.pixels().map(|p| p.0).collect();
    assert!(
        distinct.len() > 50,
        "image is nearly flat: {} colors",
        distinct.len()
    );
    let bytes = std::fs::read(&exr).unwrap();
    assert_eq!(&bytes[..4], &[0x76, 0x2f, 0x31, 0x01], "EXR magic");
    let text = String::from_utf8_lossy(&bytes);
    for ch in ["color.R", "color.diffuse.R", "color.specular.G"] {
        assert!(text.contains(ch), "EXR lacks channel {ch}");
    }
}

#[test]
fn bad_network_fails_with_message_and_leaves_output_untouched() {
    let bad = tmp("bad.json");
    std::fs::write(
        &bad,
        r#"{"nodes": [{"name": "s", "type": "lambert", "inputs": {"color": "nope.outColor"}}],
            "outputs": {"c": "s.outColor"}}"#,
    )
    .unwrap();
    let png = tmp("keep.png");
    std::fs::write(&png, b"precious").unwrap();
    let (code, _, err) = shadenet(&["shade", bad.to_str().unwrap(), "-o", png.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(
        err.contains("node `s` input `color`") && err.contains("no node `nope`"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(std::fs::read(&png).unwrap(), b"precious");
}

#[test]
fn malformed_json_and_missing_file() {
    let bad = tmp("broken.json");
    std::fs::write(&bad, "{ \"nodes\": [ }").unwrap();
    let (code, _, err) = shadenet(&["check", bad.to_str().unwrap()]);
    assert_eq!(code, 1);
    assert!(
        err.contains("malformed network") && err.contains("line 1"),
        "{err}"
    );
    let (code, _, err) = shadenet(&["check", "does/not/exist.json"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("cannot read network does/not/exist.json"),
        "{err}"
    );
}

#[test]
fn unknown_component_flag_is_an_error() {
    let png = tmp("x.png");
    let (code, _, err) = shadenet(&[
        "shade",
        "examples/networks/marble.json",
        "-o",
        png.to_str().unwrap(),
        "--components",
        "diffuse,sparkle",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("`sparkle` is not a component"), "{err}");
}

#[test]
fn compile_emits_ir_that_parses_back() {
    let (code, out, err) = shadenet(&["compile", "examples/networks/marble.json", "--emit", "ir"]);
    assert_eq!(code, 0, "{err}");
    let p = shadenet_graph::ir::parse(&out).expect("emitted IR parses");
    assert_eq!(p.to_string(), out);
}

#[test]
fn nodes_reference_matches_docs() {
    let (code, out, _) = shadenet(&["nodes"]);
    assert_eq!(code, 0);
    let doc =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/nodes.md")).unwrap();
    assert!(
        doc == out,
        "docs/nodes.md is stale: run `cargo run -- nodes > docs/nodes.md`"
    );
}

/// `diff` prints each layer's max abs difference and RMSE, fails (exit 1) naming the layers
/// beyond a bound, and names a missing file or a bad bound.
#[test]
fn diff_reports_layers_and_enforces_bounds() {
    let (a, b) = (tmp("diff-a.exr"), tmp("diff-b.exr"));
    for (exr, spp) in [(&a, "1"), (&b, "2")] {
        let (code, out, err) = shadenet(&[
            "render",
            "-o",
            exr.to_str().unwrap(),
            "--res",
            "16x12",
            "--spp",
            spp,
            "-q",
        ]);
        assert_eq!(code, 0, "{out}\n{err}");
    }
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    // An image against itself: no difference, any bound holds.
    let (code, out, err) = shadenet(&["diff", a, a, "--max-abs", "0", "--rmse", "0"]);
    assert_eq!(code, 0, "{out}\n{err}");
    let beauty = out
        .lines()
        .find(|l| l.starts_with("beauty"))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        beauty.contains("0.000e0") && beauty.contains(" 0/"),
        "{beauty}"
    );
    // 1 spp against 2 spp: the beauty differs; a zero bound fails naming it.
    let (code, out, err) = shadenet(&["diff", a, b]);
    assert_eq!(code, 0, "{out}\n{err}");
    let (code, _, err) = shadenet(&["diff", a, b, "--max-abs", "0"]);
    assert_eq!(code, 1);
    assert!(
        err.contains("beyond the bound") && err.contains("beauty"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    let (code, _, err) = shadenet(&["diff", a, "no/such.exr"]);
    assert_eq!(code, 1);
    assert!(err.contains("no/such.exr"), "{err}");
    let (code, _, err) = shadenet(&["diff", a, b, "--rmse", "NaN"]);
    assert_eq!(code, 1);
    assert!(err.contains("--rmse"), "{err}");
}

/// `shade --light` builds lights under the rules the light nodes and the scene file follow
/// (`LightDesc::new`): a bad one is an error naming the option and the field, before
/// anything is written; a good one lights the image.
#[test]
fn shade_light_option_is_checked_like_light_nodes() {
    let png = tmp("light.png");
    let run = |light: &str| {
        shadenet(&[
            "shade",
            "examples/networks/marble.json",
            "-o",
            png.to_str().unwrap(),
            "--res",
            "8x8",
            "--light",
            light,
        ])
    };
    for (light, want) in [
        ("spot:0,0,2:0,0,-1:10:400", "cone_angle"),
        ("distant:0,0,0:1", "direction is zero"),
        ("point:0,0,2:inf", "not a finite number"),
        ("laser:1", "expected point:"),
    ] {
        let _ = std::fs::remove_file(&png);
        let (code, out, err) = run(light);
        assert_eq!(code, 1, "{light}: {out}\n{err}");
        assert!(
            err.contains(&format!("--light {light}")) && err.contains(want),
            "{light}: `{want}` not in {err}"
        );
        assert!(!png.exists(), "{light}: wrote an image");
    }
    let (code, out, err) = run("spot:0,0,2:0,0,-2:10:60");
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(png.exists());
}
