//! The Python package's pytest suite (`python/tests`: the API against the CLI, distributed
//! rendering on a local Ray cluster), run by the test command through the interpreter in
//! `SHADENET_PYTHON`, where the package is installed (`.ci/run` builds it into
//! `target/venv` with `maturin develop`). Without `SHADENET_PYTHON` the test says why and
//! skips; with `CI` set it fails.

/// Runs pytest on `python/tests` and fails with its output when a Python test fails.
#[test]
fn python_package_tests() {
    let Some(python) = std::env::var_os("SHADENET_PYTHON") else {
        let why = "SHADENET_PYTHON is not set (an interpreter with the shadenet package \
                   installed: `.ci/run` sets it after `maturin develop`)";
        if std::env::var_os("CI").is_some() {
            panic!("CI runs the Python tests: {why}");
        }
        eprintln!("SKIPPED: python_package_tests: {why}");
        return;
    };
    let root = env!("CARGO_MANIFEST_DIR");
    let out = std::process::Command::new(&python)
        .args([
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "python/tests",
        ])
        .current_dir(root)
        // The Python tests compare against this build of the command line.
        .env("SHADENET_BIN", env!("CARGO_BIN_EXE_shadenet"))
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", python.to_string_lossy()));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "pytest failed:\n{text}");
    // A suite that collected nothing (a broken install) must not pass quietly.
    assert!(
        text.contains(" passed") && !text.contains("no tests ran"),
        "{text}"
    );
    eprintln!("{text}");
}
