//! The renderer's deferred mode (camera hits traced per group of tiles, then shaded per
//! shader in `shade_many` batches) against the immediate mode, with the CPU back ends: every
//! layer bit-identical, and the same rays, shading calls and non-finite counts. No GPU
//! needed: this is the path `render --backend gpu` takes, checked where the shading itself
//! is exact.

use shadenet::render::{BackendKind, RenderOptions, backend, setup_with};
use shadenet::tracer::{DeferredOptions, Film, RenderStats, ShadingMode};
use std::path::{Path, PathBuf};

fn example(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/scenes")
        .join(name)
}

fn render(
    path: &Path,
    opts: &RenderOptions,
    kind: BackendKind,
    mode: ShadingMode,
) -> (Film, RenderStats) {
    let b = backend(kind).unwrap();
    let mut r = setup_with(Some(path), opts, b.as_ref())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(r.shading_mode(), ShadingMode::Immediate, "CPU back ends");
    r.set_shading_mode(mode);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| r.render(&|_, _| {}))
}

fn assert_identical(what: &str, a: &(Film, RenderStats), b: &(Film, RenderStats)) {
    assert_eq!(a.0.layers.len(), b.0.layers.len(), "{what}");
    for (la, lb) in a.0.layers.iter().zip(&b.0.layers) {
        assert_eq!(la.name, lb.name, "{what}");
        let differing = la
            .data
            .iter()
            .zip(&lb.data)
            .filter(|(x, y)| x.to_bits() != y.to_bits())
            .count();
        assert_eq!(
            differing, 0,
            "{what}: layer {}: {differing} values differ",
            la.name
        );
    }
    let key = |s: &RenderStats| (s.rays, s.shading_calls, s.nonfinite);
    assert_eq!(key(&a.1), key(&b.1), "{what}: statistics");
}

/// The Cornell box in eight passes (mirror and glass: traced rays from inside the batches;
/// the occlusion pass: an override shaded in the batches; area-light shadow rays), the
/// glass spheres and the default scene, with the interpreter and the JIT, in groups of a
/// few tiles and in groups larger than the frame.
#[test]
fn deferred_and_immediate_renders_are_identical() {
    let opts = RenderOptions {
        spp: Some(2),
        res: Some((24, 20)),
        passes: None,
        light_strategy: None,
    };
    for scene in ["cornell.toml", "cornell_glass.toml", "default.toml"] {
        let path = example(scene);
        for kind in [BackendKind::Interp, BackendKind::Jit] {
            let immediate = render(&path, &opts, kind, ShadingMode::Immediate);
            assert_eq!(immediate.1.batches, 0);
            for group in [300, DeferredOptions::DEFAULT_GROUP_SAMPLES] {
                let deferred = render(
                    &path,
                    &opts,
                    kind,
                    ShadingMode::Deferred(DeferredOptions {
                        group_samples: group,
                    }),
                );
                let what = format!("{scene}, {kind:?}, groups of {group} samples");
                assert_identical(&what, &immediate, &deferred);
                let s = &deferred.1;
                assert!(s.batches > 0 && s.batched_fragments > 0, "{what}: {s:?}");
                // Camera hits are batched; shading from inside traced rays is not.
                assert!(s.batched_fragments <= s.shading_calls, "{what}: {s:?}");
                eprintln!(
                    "{what}: {} batches, {} of {} shading calls batched, largest {}",
                    s.batches, s.batched_fragments, s.shading_calls, s.largest_batch
                );
            }
        }
    }
}

/// `render --shading deferred` writes the EXR `--shading immediate` writes, byte for byte,
/// and says which mode it used and how it batched.
#[test]
fn cli_shading_modes_write_the_same_exr() {
    let dir = std::env::temp_dir().join(format!("shadenet-deferred-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut files = Vec::new();
    for mode in ["immediate", "deferred"] {
        let exr = dir.join(format!("{mode}.exr"));
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_shadenet"))
            .args([
                "render",
                "examples/scenes/cornell_glass.toml",
                "-o",
                exr.to_str().unwrap(),
                "--res",
                "20x16",
                "--spp",
                "1",
                "--shading",
                mode,
            ])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(stdout.contains(&format!("{mode} ")), "{stdout}");
        assert_eq!(
            stdout.contains("deferred shading: "),
            mode == "deferred",
            "{stdout}"
        );
        files.push(std::fs::read(&exr).unwrap());
    }
    assert!(files[0] == files[1], "the EXRs differ");
    let _ = std::fs::remove_dir_all(&dir);
}
