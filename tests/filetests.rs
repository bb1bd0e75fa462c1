//! Filetests for the optimizer passes (Cranelift-style): `tests/filetests/<pass>/*.ir`.
//!
//! Each file is an IR program, optionally preceded by a `; spec:` line, followed by
//! `; check:` lines holding the program as printed after running the pass named by the
//! directory (`pipeline` runs the whole `opt::run`). `SHADENET_BLESS=1 cargo test --test
//! filetests` rewrites the check lines from the current output.
//!
//! `; spec:` takes space-separated `key=value` settings: `components=a,b` (active
//! components, by name; default all), `raytypes=camera,shadow,…` (default all), `bake=false`
//! (class compilation; default true), `no=cse,fold,…` (passes switched off).

use shadenet_graph::ir::{RAY_CAMERA, RAY_DIFFUSE, RAY_REFLECTION, RAY_REFRACTION, RAY_SHADOW};
use shadenet_graph::ir::{Program, parse, validate};
use shadenet_graph::opt::{self, Specialization};
use std::path::Path;

fn spec_of(line: Option<&str>, p: &Program) -> Specialization {
    let mut spec = Specialization::default();
    let Some(line) = line else { return spec };
    for kv in line.split_whitespace() {
        let (k, v) = kv.split_once('=').unwrap_or_else(|| panic!("bad spec item {kv}"));
        let list: Vec<String> = v.split(',').filter(|s| !s.is_empty()).map(String::from).collect();
        match k {
            "components" => spec.components = Specialization::mask_of(p, &list).unwrap(),
            "raytypes" => {
                spec.ray_types = list
                    .iter()
                    .map(|r| match r.as_str() {
                        "camera" => RAY_CAMERA,
                        "shadow" => RAY_SHADOW,
                        "reflection" => RAY_REFLECTION,
                        "refraction" => RAY_REFRACTION,
                        "diffuse" => RAY_DIFFUSE,
                        other => panic!("unknown ray type {other}"),
                    } as u32)
                    .fold(0, |a, b| a | b)
            }
            "bake" => spec.bake = v == "true",
            "no" => {
                for pass in &list {
                    match pass.as_str() {
                        "fold" => spec.passes.fold = false,
                        "specialize" => spec.passes.specialize = false,
                        "dead_branch" => spec.passes.dead_branch = false,
                        "cse" => spec.passes.cse = false,
                        "dce" => spec.passes.dce = false,
                        "hoist" => spec.passes.hoist = false,
                        other => panic!("unknown pass {other}"),
                    }
                }
            }
            other => panic!("unknown spec key {other}"),
        }
    }
    spec
}

fn run_file(pass: &str, path: &Path, bless: bool) -> Result<(), String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut input = String::new();
    let mut checks = Vec::new();
    let mut spec_line = None;
    for line in text.lines() {
        if let Some(c) = line.strip_prefix("; check:") {
            checks.push(c.strip_prefix(' ').unwrap_or(c).to_string());
        } else {
            if let Some(s) = line.strip_prefix("; spec:") {
                spec_line = Some(s.trim().to_string());
            }
            input.push_str(line);
            input.push('\n');
        }
    }
    let mut p = parse(&input).map_err(|e| format!("{}: {e}", path.display()))?;
    validate(&p).map_err(|e| format!("{}: input invalid: {e}", path.display()))?;
    let spec = spec_of(spec_line.as_deref(), &p);
    if pass == "pipeline" {
        p = opt::run(&p, &spec).0;
    } else {
        let f = opt::pass(pass).unwrap_or_else(|| panic!("no pass {pass}"));
        f(&mut p, &spec);
    }
    validate(&p).map_err(|e| format!("{}: output invalid: {e}\n{p}", path.display()))?;
    let got: Vec<String> = p.to_string().lines().map(String::from).collect();
    if got == checks {
        return Ok(());
    }
    if bless {
        let mut out = input.trim_end().to_string();
        out.push('\n');
        for l in &got {
            out.push_str(format!("; check: {l}").trim_end());
            out.push('\n');
        }
        std::fs::write(path, out).unwrap();
        return Ok(());
    }
    Err(format!(
        "{}: output differs (SHADENET_BLESS=1 to accept)\n--- expected\n{}\n--- got\n{}",
        path.display(),
        checks.join("\n"),
        got.join("\n")
    ))
}

#[test]
fn filetests() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/filetests");
    let bless = std::env::var("SHADENET_BLESS").is_ok_and(|v| v == "1");
    let mut failures = Vec::new();
    let mut count = 0;
    let mut dirs: Vec<_> = std::fs::read_dir(&root).unwrap().map(|e| e.unwrap().path()).collect();
    dirs.sort();
    for dir in dirs {
        let pass = dir.file_name().unwrap().to_string_lossy().into_owned();
        let mut files: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
        files.sort();
        for f in files.iter().filter(|f| f.extension().is_some_and(|e| e == "ir")) {
            count += 1;
            if let Err(e) = run_file(&pass, f, bless) {
                failures.push(e);
            }
        }
    }
    assert!(count > 0, "no filetests found");
    assert!(failures.is_empty(), "{} of {count} filetests failed:\n\n{}", failures.len(), failures.join("\n\n"));
}
