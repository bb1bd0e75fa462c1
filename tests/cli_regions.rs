//! Region rendering: `render --crop` gives a window's pixels exactly the bits of a full
//! render, whatever the back end and shading mode; `shadenet merge` assembles the parts
//! into the file a full render writes, and refuses gaps, overlaps and mismatched parts
//! without writing anything.

mod common;
use common::shadenet;
use shadenet::output::read_exr;
use shadenet::tracer::Window;
use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    common::tmp("regions", name)
}

/// Renders the default scene at 40×24, 2 spp, with `extra` arguments, to `out`.
fn render(out: &Path, extra: &[&str]) {
    let mut args = vec![
        "render",
        "-o",
        out.to_str().unwrap(),
        "--res",
        "40x24",
        "--spp",
        "2",
        "-q",
    ];
    args.extend_from_slice(extra);
    let (code, o, e) = shadenet(&args);
    assert_eq!(code, 0, "{args:?}\n{o}\n{e}");
}

#[test]
fn crops_hold_the_full_render_bits_and_merge_into_its_file() {
    let full = tmp("full.exr");
    render(&full, &[]);
    // Three parts, each by another path through the renderer: the JIT immediately, the
    // JIT deferred in batches, the interpreter.
    let parts = [
        (tmp("a.exr"), "0,0,17,10", vec!["--backend", "jit"]),
        (tmp("b.exr"), "17,0,40,10", vec!["--shading", "deferred"]),
        (tmp("c.exr"), "0,10,40,24", vec!["--backend", "interp"]),
    ];
    let whole = read_exr(&full).unwrap();
    for (path, crop, extra) in &parts {
        let mut args = vec!["--crop", crop];
        args.extend(extra.iter().copied());
        render(path, &args);
        let part = read_exr(path).unwrap();
        let c: Vec<u32> = crop.split(',').map(|x| x.parse().unwrap()).collect();
        let window = Window::new([c[0], c[1], c[2], c[3]], (40, 24)).unwrap();
        assert_eq!((part.window, part.frame), (window, (40, 24)), "{crop}");
        assert_eq!((part.width, part.height), (window.width(), window.height()));
        // Every channel of the part is the full render's window, bit for bit.
        for ((name, got), (wname, want)) in part.channels.iter().zip(&whole.channels) {
            assert_eq!(name, wname);
            let cut: Vec<u32> = (window.y0..window.y1)
                .flat_map(|y| (window.x0..window.x1).map(move |x| (y * 40 + x) as usize))
                .map(|i| want[i].to_bits())
                .collect();
            let got: Vec<u32> = got.iter().map(|v| v.to_bits()).collect();
            assert_eq!(got, cut, "{crop}: channel {name}");
        }
    }
    let merged = tmp("merged.exr");
    let p: Vec<&str> = parts.iter().map(|p| p.0.to_str().unwrap()).collect();
    let (code, out, err) = shadenet(&["merge", p[0], p[1], p[2], "-o", merged.to_str().unwrap()]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(out.contains("merged 3 parts"), "{out}");
    // The same file as the full render, byte for byte.
    assert_eq!(
        std::fs::read(&merged).unwrap(),
        std::fs::read(&full).unwrap()
    );
}

#[test]
fn bad_crops_and_bad_merges_are_errors_that_write_nothing() {
    let out = tmp("bad.exr");
    std::fs::write(&out, b"keep").unwrap();
    // Exit status 2: the argument parser refused the value.
    for (crop, want, status) in [
        ("0,0,41,5", "reaches outside the 40×24 frame", 1),
        ("3,3,3,9", "is empty", 1),
        ("9,0,2,5", "is empty", 1),
        ("1,2,3", "expected X0,Y0,X1,Y1", 2),
        ("1,2,3,-4", "expected X0,Y0,X1,Y1", 2),
    ] {
        let (code, _, err) = shadenet(&[
            "render",
            "-o",
            out.to_str().unwrap(),
            "--res",
            "40x24",
            "--crop",
            crop,
        ]);
        assert_eq!(code, status, "{crop}");
        assert!(err.contains(want), "{crop}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let (top, bottom, overlap) = (tmp("top.exr"), tmp("bottom.exr"), tmp("mid.exr"));
    render(&top, &["--crop", "0,0,40,12"]);
    render(&bottom, &["--crop", "0,12,40,24"]);
    render(&overlap, &["--crop", "0,8,40,16"]);
    let other = tmp("other-frame.exr");
    let (code, o, e) = shadenet(&[
        "render",
        "-o",
        other.to_str().unwrap(),
        "--res",
        "40x30",
        "--spp",
        "1",
        "-q",
        "--crop",
        "0,12,40,30",
    ]);
    assert_eq!(code, 0, "{o}\n{e}");
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();
    // Each bad set of parts, what the error says and the files it names.
    for (parts, want, named) in [
        (vec![s(&top)], "some are missing", vec![s(&top)]),
        (
            vec![s(&top), s(&bottom), s(&overlap)],
            "overlap",
            vec![s(&top), s(&overlap)],
        ),
        (
            vec![s(&top), s(&other)],
            "of a 40×30 frame",
            vec![s(&top), s(&other)],
        ),
        (vec![s(&top), "no/such.exr".into()], "no/such.exr", vec![]),
    ] {
        let mut args = vec!["merge".to_string()];
        args.extend(parts.iter().cloned());
        args.extend(["-o".into(), s(&out)]);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, _, err) = shadenet(&args);
        assert_eq!(code, 1, "{parts:?}");
        assert!(err.contains(want), "{parts:?}: {err}");
        for p in &named {
            assert!(err.contains(p.as_str()), "{err} should name {p}");
        }
    }
    assert_eq!(std::fs::read(&out).unwrap(), b"keep", "no partial output");
}
