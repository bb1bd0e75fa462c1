//! MaterialX benchmarks (issue 13's performance figures): loading and indexing the data
//! libraries, and parse + link + optimize + JIT of documents whose library nodegraphs expand
//! to large networks — the workload partial evaluation exists for.
//!
//! `cargo bench --bench mtlx` prints a table (per example document: nodes after expansion,
//! IR ops before and after optimization, the best of a few runs of each step, one thread),
//! then runs criterion on the library load and on the largest document.
//! The libraries come from `SHADENET_MTLX_LIBRARIES` (or `MATERIALX_SEARCH_PATH`): without
//! them the bench says so and exits; `.ci/run` installs them under `target/venv`.
//! `cargo test --benches` runs a quick check instead (every example compiles).

use criterion::{Criterion, criterion_group};
use shadenet::graph::mtlx::{self, Library, Selection};
use shadenet::graph::opt::{self, Specialization};
use shadenet::runtime::Backend;
use shadenet_jit::JitBackend;
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn libraries() -> Option<PathBuf> {
    shadenet::mtlx::locate(None).ok()
}

/// A generated document whose library nodegraphs expand to well over 300 nodes: `stages`
/// colour-grading stages (`hsvadjust` → `contrast` → `range` → `colorcorrect`, each a
/// library nodegraph) in a chain over a ramp.
fn graded_chain(stages: usize) -> String {
    let mut body = String::from(
        r#"  <ramplr name="s0" type="color3">
    <input name="valuel" type="color3" value="0.05, 0.1, 0.4" />
    <input name="valuer" type="color3" value="0.95, 0.6, 0.2" />
  </ramplr>
"#,
    );
    for i in 1..=stages {
        let prev = format!("s{}", i - 1);
        body += &format!(
            r#"  <hsvadjust name="h{i}" type="color3">
    <input name="in" type="color3" nodename="{prev}" />
    <input name="amount" type="vector3" value="0.01, 1.05, 1.0" />
  </hsvadjust>
  <contrast name="c{i}" type="color3">
    <input name="in" type="color3" nodename="h{i}" />
    <input name="amount" type="float" value="1.1" />
  </contrast>
  <range name="r{i}" type="color3">
    <input name="in" type="color3" nodename="c{i}" />
    <input name="doclamp" type="boolean" value="true" />
  </range>
  <colorcorrect name="s{i}" type="color3">
    <input name="in" type="color3" nodename="r{i}" />
    <input name="gamma" type="float" value="1.02" />
  </colorcorrect>
"#
        );
    }
    format!(
        "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n{body}  <output name=\"out\" type=\"color3\" nodename=\"s{stages}\" />\n</materialx>\n"
    )
}

/// The example documents and the generated chain, by name.
fn documents() -> Vec<(String, String)> {
    let mut v = examples();
    v.push(("graded_chain".into(), graded_chain(6)));
    v
}

fn examples() -> Vec<(String, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/materials");
    let mut v: Vec<(String, String)> = std::fs::read_dir(&dir)
        .expect("examples/materials")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mtlx"))
        .map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).expect("readable example"))
        })
        .collect();
    v.sort();
    v
}

/// One document through every step, timed: (expanded nodes, ops before, ops after, parse +
/// translate, link + lower, optimize, JIT).
fn steps(lib: &Library, name: &str, text: &str) -> (usize, usize, usize, [Duration; 4]) {
    let t0 = Instant::now();
    let net = mtlx::network(name, text, lib, &Selection::default()).expect("translates");
    let t1 = Instant::now();
    let linked = shadenet::graph::link::link(&net, lib.atoms()).expect("links");
    let mut program = shadenet::graph::lower::lower(&linked, lib.atoms()).expect("lowers");
    // The example documents name their files relative to their folder (maps.mtlx).
    program.resolve_textures(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/materials"
    )));
    let t2 = Instant::now();
    let spec = Specialization::default();
    let (optimized, report) = opt::run(&program, &spec);
    let t3 = Instant::now();
    let m = JitBackend::new()
        .compile(&optimized, &spec)
        .expect("JIT compiles");
    let t4 = Instant::now();
    black_box(m);
    (
        linked.nodes.len(),
        report.ops_before,
        report.ops_after,
        [t1 - t0, t2 - t1, t3 - t2, t4 - t3],
    )
}

fn table(lib: &Library) {
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    let load = (0..3)
        .map(|_| {
            let t = Instant::now();
            black_box(shadenet::mtlx::read_library(&libraries().unwrap()).expect("libraries"));
            t.elapsed()
        })
        .min()
        .unwrap();
    println!(
        "MaterialX libraries: read + parse + index {:.1} ms",
        ms(load)
    );
    println!(
        "{:<14} {:>6} {:>10} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "document", "nodes", "ops before", "ops after", "parse", "link", "optimize", "JIT", "total"
    );
    for (name, text) in documents() {
        let best = (0..5)
            .map(|_| steps(lib, &name, &text))
            .min_by_key(|r| r.3.iter().sum::<Duration>())
            .unwrap();
        let (nodes, before, after, t) = best;
        println!(
            "{:<14} {:>6} {:>10} {:>9} {:>7.2}ms {:>6.2}ms {:>6.2}ms {:>6.2}ms {:>6.2}ms",
            name,
            nodes,
            before,
            after,
            ms(t[0]),
            ms(t[1]),
            ms(t[2]),
            ms(t[3]),
            ms(t.iter().sum())
        );
    }
}

fn bench(c: &mut Criterion) {
    let dir = libraries().unwrap();
    c.bench_function("mtlx/library_load", |b| {
        b.iter(|| black_box(shadenet::mtlx::read_library(&dir).expect("libraries")))
    });
    let lib = shadenet::mtlx::read_library(&dir).expect("libraries");
    let (name, text) = documents()
        .into_iter()
        .max_by_key(|(n, t)| steps(&lib, n, t).0)
        .unwrap();
    c.bench_function(&format!("mtlx/compile_{name}"), |b| {
        b.iter(|| black_box(steps(&lib, &name, &text)))
    });
}

criterion_group!(benches, bench);

fn main() {
    let Some(dir) = libraries() else {
        println!(
            "mtlx bench: skipped: the MaterialX libraries were not found (set SHADENET_MTLX_LIBRARIES)"
        );
        return;
    };
    let lib = shadenet::mtlx::read_library(&dir).expect("libraries");
    if !std::env::args().any(|a| a == "--bench") {
        for (name, text) in documents() {
            steps(&lib, &name, &text);
        }
        let nodes = steps(&lib, "graded_chain", &graded_chain(6)).0;
        assert!(
            nodes >= 300,
            "the generated document expands to {nodes} nodes, not ≥ 300"
        );
        println!("mtlx bench smoke check: every example compiles (run `cargo bench --bench mtlx`)");
        return;
    }
    // One thread, as the target says.
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .ok();
    table(&lib);
    benches();
    Criterion::default().configure_from_args().final_summary();
}
