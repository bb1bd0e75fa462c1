//! The exact text of one error per kind, as the CLI prints it: each cause once, outermost
//! first (`error: bad.json: malformed network: EOF while parsing a list at line 2 column 0`),
//! never the same cause two or four times over.

mod common;
use common::shadenet;

use std::path::PathBuf;

fn write(name: &str, text: &str) -> PathBuf {
    let p = common::tmp("errors", name);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs the CLI, expects exit code 1 and returns stderr's error line (notes dropped).
fn error_of(args: &[&str]) -> String {
    let (code, out, err) = shadenet(args);
    assert_eq!(code, 1, "{args:?}\nstdout: {out}\nstderr: {err}");
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("error: ")).collect();
    assert_eq!(lines.len(), 1, "one error line expected: {err}");
    lines[0].to_string()
}

#[test]
fn parse_error_says_its_cause_once() {
    let p = write("bad.json", "{\"nodes\": [\n");
    assert_eq!(
        error_of(&["check", p.to_str().unwrap()]),
        format!(
            "error: {}: malformed network: EOF while parsing a list at line 2 column 0",
            p.display()
        )
    );
}

#[test]
fn link_error_names_node_port_and_reference() {
    let p = write(
        "link.json",
        r#"{"nodes": [{"name": "s", "type": "lambert", "inputs": {"color": "nope.outColor"}}],
            "outputs": {"c": "s.outColor"}}"#,
    );
    assert_eq!(
        error_of(&["check", p.to_str().unwrap()]),
        format!(
            "error: {}: node `s` input `color`: connection `nope.outColor` names no node `nope`",
            p.display()
        )
    );
}

#[test]
fn type_error_names_node_port_and_both_types() {
    let p = write(
        "type.json",
        r#"{"nodes": [{"name": "s", "type": "lambert", "inputs": {"diffuse": "i.uv"}},
                      {"name": "i", "type": "samplerInfo"}],
            "outputs": {"c": "s.outColor"}}"#,
    );
    assert_eq!(
        error_of(&["check", p.to_str().unwrap()]),
        format!(
            "error: {}: node `s` input `diffuse`: type mismatch: the input is float, but `i.uv` is vec2",
            p.display()
        )
    );
}

#[test]
fn missing_files_say_the_os_error_once() {
    let net = common::tmp("errors", "nonexist.json");
    assert_eq!(
        error_of(&["check", net.to_str().unwrap()]),
        format!(
            "error: cannot read network {}: No such file or directory (os error 2)",
            net.display()
        )
    );
    let scene = common::tmp("errors", "nonexist.toml");
    let out = common::tmp("errors", "never.exr");
    assert_eq!(
        error_of(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap()
        ]),
        format!(
            "error: cannot read scene {}: No such file or directory (os error 2)",
            scene.display()
        )
    );
    assert!(!out.exists());
}

#[test]
fn texture_error_names_the_file_once() {
    let p = write(
        "tex.json",
        r#"{"nodes": [{"name": "t", "type": "file", "inputs": {"fileTextureName": "missing.png"}}],
            "outputs": {"c": "t.outColor"}}"#,
    );
    let png = common::tmp("errors", "tex.png");
    let missing = p.parent().unwrap().join("missing.png");
    assert_eq!(
        error_of(&[
            "shade",
            p.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--res",
            "4x4"
        ]),
        format!(
            "error: cannot load texture {}: No such file or directory (os error 2)",
            missing.display()
        )
    );
    assert!(!png.exists());
}

#[test]
fn scene_key_error_names_the_key_and_the_range() {
    let p = write(
        "key.toml",
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n[render]\nspp = 0\n",
    );
    let exr = common::tmp("errors", "key.exr");
    assert_eq!(
        error_of(&["render", p.to_str().unwrap(), "-o", exr.to_str().unwrap()]),
        format!(
            "error: {}: `render.spp`: 0 is out of range: must be 1 to 65536",
            p.display()
        )
    );
    assert!(!exr.exists());
}
