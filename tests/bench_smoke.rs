//! `shadenet bench --quick` at a tiny size: every suite runs (B6 where the MaterialX
//! libraries are found: always under `CI`), every row has its columns, the
//! CSV parses with one field per column and the SVG is well-formed enough to render.

use shadenet::bench::{self, BenchOptions, report};

#[test]
fn quick_bench_runs_every_suite_at_a_tiny_size() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let opts = BenchOptions {
        quick: true,
        size: Some((16, 12)),
        levels: Some(vec![1, 4]),
        scenes: root.join("examples/scenes"),
        ..BenchOptions::default()
    };
    let results = bench::run(&opts, |_| {});
    let names: Vec<_> = results.iter().map(|r| r.name).collect();
    assert_eq!(names, ["B1", "B2", "B3", "B4", "B5", "B6", "B7", "B8"]);
    // B8 (its own test: tests/bench_b8.rs): three filterings × 1, 4, 16 spp.
    assert_eq!(results[7].rows.len(), 9, "{}", results[7].extra);
    // B7 prints OSL's figures beside ours, labelled as quoted.
    let b7 = &results[6];
    assert_eq!(b7.rows.len(), 3);
    assert!(b7.extra.contains("quoted") && b7.extra.contains("32.6 ms"));
    // B6 renders pbr.toml per light strategy (MaterialX materials): 3 strategies × 4 spp,
    // the equal-time table after; without the MaterialX libraries it says why it did not run.
    let b6 = &results[5];
    if b6.rows.is_empty() && std::env::var_os("CI").is_none() {
        assert!(b6.extra.contains("did not run"), "{}", b6.extra);
    } else {
        assert_eq!(b6.rows.len(), 12, "{}", b6.extra);
        assert!(b6.extra.contains("Error at equal time"), "{}", b6.extra);
        for s in [
            "light_strategy mis",
            "light_strategy light",
            "light_strategy bsdf",
        ] {
            assert_eq!(
                b6.rows.iter().filter(|r| r.config.starts_with(s)).count(),
                4
            );
        }
        assert!(
            b6.rows
                .iter()
                .all(|r| r.error.is_some_and(|e| e.rmse > 0.0))
        );
    }
    for r in &results {
        if r.name == "B6" && r.rows.is_empty() {
            continue;
        }
        assert!(!r.rows.is_empty(), "{} has rows", r.name);
        let csv = report::csv(&r.rows);
        let mut lines = csv.lines();
        let head = lines.next().unwrap();
        assert_eq!(head.split("\",\"").count(), report::COLUMNS.len());
        for l in lines {
            assert_eq!(l.split("\",\"").count(), report::COLUMNS.len(), "{l}");
        }
        let svg = report::svg(r.name, &r.rows);
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    }
    // The native reference is there, rustc-compiled, and agrees with the interpreter.
    let b1 = &results[0].rows;
    let native = b1
        .iter()
        .find(|r| r.backend == "native (rustc)" && r.case == "L4 world shade");
    if cfg!(target_arch = "x86_64") {
        let e = native.expect("a native row").error.unwrap();
        assert_eq!(e.differing, 0);
    }
    let dir = std::env::temp_dir().join(format!("shadenet-bench-smoke-{}", std::process::id()));
    let md = bench::write(&dir, &results, &opts, 0.0).unwrap();
    assert!(md.contains("Larsson 2005"));
    assert!(dir.join("b1.csv").exists() && dir.join("b5.svg").exists());
    assert!(
        std::fs::read_to_string(dir.join("b6.svg"))
            .unwrap()
            .contains("RMSE vs render time")
    );
    let _ = std::fs::remove_dir_all(&dir);
}
