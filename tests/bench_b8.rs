//! `shadenet bench --quick --suite b8`: texture filtering's speed against error on
//! `texture_plane.toml`. Three filterings × 1, 4, 16 spp; every error finite; the unfiltered
//! renders converge (error falls from 1 to 16 spp); the target check is stated; the
//! reference is cached in the output folder and a second run reuses it, to the same errors.

use shadenet::bench::textures::{self, B8_QUICK_REFERENCE_SPP, B8_QUICK_SIZE};
use shadenet::bench::{self, BenchOptions};

#[test]
fn quick_b8_measures_three_filterings_and_caches_its_reference() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::env::temp_dir().join(format!("shadenet-bench-b8-{}", std::process::id()));
    let opts = BenchOptions {
        quick: true,
        suites: vec!["b8".into()],
        scenes: root.join("examples/scenes"),
        out: Some(out.clone()),
        ..BenchOptions::default()
    };
    let results = bench::run(&opts, |_| {});
    assert_eq!(results.len(), 1);
    let b8 = &results[0];
    assert_eq!(b8.name, "B8");
    assert_eq!(b8.rows.len(), 9, "{}", b8.extra);
    for (i, f) in ["unfiltered", "trilinear", "anisotropic"]
        .iter()
        .enumerate()
    {
        for (j, spp) in [1u64, 4, 16].iter().enumerate() {
            let r = &b8.rows[3 * i + j];
            assert!(r.config.starts_with(&format!("{f}, ")), "{}", r.config);
            assert!(r.case.ends_with(&format!(" {spp} spp")), "{}", r.case);
            assert_eq!(r.work, 96 * 54 * spp);
            let e = r.error.unwrap();
            assert!(e.rmse.is_finite() && e.rmse > 0.0 && e.max_abs.is_finite());
        }
    }
    let rmse = |i: usize| b8.rows[i].error.unwrap().rmse;
    assert!(rmse(0) > rmse(1) && rmse(1) > rmse(2), "{}", b8.extra);
    assert!(
        b8.extra
            .contains("| filtering | spp | time ms | RMSE | relMSE | SSIM |")
    );
    assert!(b8.extra.contains("Target check (issue 16)"), "{}", b8.extra);
    assert!(b8.extra.contains("**holds**") || b8.extra.contains("**does not hold**"));
    let cache = textures::reference_path(&out, B8_QUICK_SIZE, B8_QUICK_REFERENCE_SPP);
    assert!(b8.extra.contains("cached in"), "{}", b8.extra);
    assert_eq!(
        std::fs::metadata(&cache).unwrap().len(),
        24 + 4 * 3 * 96 * 54
    );
    // The second run reads the reference back: the same errors, bit for bit.
    let again = bench::run(&opts, |_| {});
    assert!(again[0].extra.contains("read from"), "{}", again[0].extra);
    let errors = |r: &bench::SuiteResult| -> Vec<_> { r.rows.iter().map(|r| r.error).collect() };
    assert_eq!(errors(b8), errors(&again[0]));
    let md = bench::write(&out, &results, &opts, 0.0).unwrap();
    assert!(md.contains("## B8"));
    assert!(out.join("b8.csv").exists());
    let svg = std::fs::read_to_string(out.join("b8.svg")).unwrap();
    assert!(svg.contains("RMSE vs render time") && svg.matches("<polyline").count() == 3);
    let _ = std::fs::remove_dir_all(&out);
}
