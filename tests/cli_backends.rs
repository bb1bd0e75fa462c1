//! `shadenet shade --backend` and `shadenet compile --emit clif / --stats` with the JIT.

mod common;
use common::shadenet;

use std::path::PathBuf;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shadenet-cli-jit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// On every example network, every back end writes the same EXR, bit for bit (odd width:
/// the batch entry pads each row's last packet).
#[test]
fn every_backend_writes_the_same_image() {
    let mut networks: Vec<PathBuf> = std::fs::read_dir("examples/networks")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    networks.sort();
    assert!(networks.len() >= 7, "{networks:?}");
    for network in &networks {
        let stem = network.file_stem().unwrap().to_string_lossy().to_string();
        let mut files = Vec::new();
        for backend in ["interp", "jit", "jit-batch"] {
            let exr = tmp(&format!("{stem}-{backend}.exr"));
            let (code, out, err) = shadenet(&[
                "shade",
                network.to_str().unwrap(),
                "-o",
                exr.to_str().unwrap(),
                "--res",
                "37x21",
                "--backend",
                backend,
            ]);
            assert_eq!(code, 0, "{stem}: {out}\n{err}");
            assert!(out.contains(&format!("f32, {backend})")), "{stem}: {out}");
            assert!(out.contains("compile:"), "{stem}: {out}");
            files.push(std::fs::read(&exr).unwrap());
        }
        assert!(
            files[0] == files[1] && files[1] == files[2],
            "{stem}: the back ends' images differ"
        );
    }
}

#[test]
fn the_default_backend_is_the_jit_and_f64_is_the_interpreter() {
    let png = tmp("default.png");
    let (code, out, err) = shadenet(&[
        "shade",
        "examples/networks/cells.json",
        "-o",
        png.to_str().unwrap(),
        "--res",
        "16x16",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("f32, jit)"), "{out}");
    let (code, out, err) = shadenet(&[
        "shade",
        "examples/networks/cells.json",
        "-o",
        png.to_str().unwrap(),
        "--res",
        "16x16",
        "--precision",
        "f64",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("f64, interp)"), "{out}");
    let (code, _, err) = shadenet(&[
        "shade",
        "examples/networks/cells.json",
        "-o",
        png.to_str().unwrap(),
        "--precision",
        "f64",
        "--backend",
        "jit-batch",
    ]);
    assert_eq!(code, 1);
    assert!(err.contains("f64") && err.contains("interpreter"), "{err}");
}

#[test]
fn compile_emits_clif_and_jit_statistics() {
    let (code, out, err) =
        shadenet(&["compile", "examples/networks/marble.json", "--emit", "clif"]);
    assert_eq!(code, 0, "{err}");
    for want in [
        "; scalar entry of material `marble`",
        "; batch entry of material `marble`",
        "sn_fbm3",
        "f32x4",
        "function u0:",
    ] {
        assert!(out.contains(want), "missing {want:?} in\n{out}");
    }
    let (code, out, err) = shadenet(&["compile", "examples/networks/marble.json", "--stats"]);
    assert_eq!(code, 0, "{err}");
    let line = out
        .lines()
        .find(|l| l.starts_with("jit: "))
        .expect("a jit line");
    for want in [
        "lower",
        "codegen",
        "link",
        "bytes of code",
        "IR instructions",
    ] {
        assert!(line.contains(want), "{line}");
    }
    let (code, _, err) = shadenet(&["compile", "examples/networks/marble.json", "--emit", "asm"]);
    assert_eq!(code, 1);
    assert!(err.contains("clif"), "{err}");
}

/// `--frames N` shades N times into the same buffer: the image is the one frame's, bit for
/// bit, and the summary gives the later frames' median; 0 frames is refused.
#[test]
fn frames_reuse_the_buffer_and_report_the_median() {
    let mut files = Vec::new();
    for (backend, frames) in [("jit-batch", "1"), ("jit-batch", "3"), ("jit", "2")] {
        let exr = tmp(&format!("frames-{backend}-{frames}.exr"));
        let (code, out, err) = shadenet(&[
            "shade",
            "examples/networks/tiles.json",
            "-o",
            exr.to_str().unwrap(),
            "--res",
            "19x7",
            "--backend",
            backend,
            "--frames",
            frames,
        ]);
        assert_eq!(code, 0, "{out}\n{err}");
        let later = frames.parse::<u32>().unwrap();
        assert_eq!(
            out.contains(&format!("frames 2..{later}: median")),
            later > 1,
            "{out}"
        );
        files.push(std::fs::read(&exr).unwrap());
    }
    assert!(files[0] == files[1] && files[1] == files[2]);
    let (code, _, err) = shadenet(&[
        "shade",
        "examples/networks/tiles.json",
        "-o",
        tmp("frames0.png").to_str().unwrap(),
        "--frames",
        "0",
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--frames"), "{err}");
}
