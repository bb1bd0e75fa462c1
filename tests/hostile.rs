//! Hostile values and hostile command lines: each ends with exit code 1 and a clear error,
//! never a panic, a hang or a huge allocation, and never touches an existing output.
//!
//! The commands run under an address-space limit (`ulimit -v`, i.e. `RLIMIT_AS`) so that
//! reading an endless input to its end would fail the test instead of eating the machine's
//! memory; a generous wall-clock guard kills a command that hangs (a guard against hanging,
//! not a timing assertion).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The address space a command may use: ample for `check`, `shade` and `render` of small
/// inputs (they need under 256 MiB), far too little to hold an endless input.
const ADDRESS_SPACE_KIB: u64 = 1 << 20;

/// How long a command may run before the guard kills it and the test fails.
const GUARD: Duration = Duration::from_secs(120);

fn tmp(name: &str) -> PathBuf {
    common::tmp("hostile", name)
}

/// Runs the CLI under the address-space limit and the guard: (exit code, stderr).
fn run_limited(args: &[&str]) -> (i32, String) {
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v {ADDRESS_SPACE_KIB} && exec \"$0\" \"$@\""
        ))
        .arg(env!("CARGO_BIN_EXE_shadenet"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run sh");
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            use std::io::Read;
            child
                .stderr
                .take()
                .unwrap()
                .read_to_string(&mut err)
                .unwrap();
            return (status.code().unwrap_or(-1), err);
        }
        if start.elapsed() > GUARD {
            let _ = child.kill();
            panic!("shadenet {args:?} still running after {GUARD:?}: it hangs");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn check_of_dev_zero_is_refused_before_reading() {
    let (code, err) = run_limited(&["check", "/dev/zero"]);
    assert_eq!(code, 1, "{err}");
    assert_eq!(
        err.trim(),
        "error: /dev/zero: not a regular file (a character device); text input must be a regular file"
    );
}

#[test]
fn sparse_gigabyte_network_is_refused_by_its_size() {
    let p = tmp("huge.json");
    let f = std::fs::File::create(&p).unwrap();
    f.set_len(1 << 30).unwrap();
    drop(f);
    let (code, err) = run_limited(&["check", p.to_str().unwrap()]);
    std::fs::remove_file(&p).unwrap();
    assert_eq!(code, 1, "{err}");
    assert_eq!(
        err.trim(),
        format!(
            "error: {}: 1073741824 bytes is over the 67108864-byte limit for text files (set SHADENET_MAX_TEXT_BYTES to raise it)",
            p.display()
        )
    );
}

#[test]
fn the_text_limit_can_be_raised_and_lowered() {
    let net = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/networks/cells.json");
    let (code, _, err) = common::shadenet_env(
        &["check", net.to_str().unwrap()],
        &[("SHADENET_MAX_TEXT_BYTES", "100")],
    );
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("over the 100-byte limit for text files"),
        "{err}"
    );
    let (code, out, err) = common::shadenet_env(
        &["check", net.to_str().unwrap()],
        &[("SHADENET_MAX_TEXT_BYTES", "64M")],
    );
    assert_eq!(code, 0, "{out}{err}");
    let (code, _, err) = common::shadenet_env(
        &["check", net.to_str().unwrap()],
        &[("SHADENET_MAX_TEXT_BYTES", "lots")],
    );
    assert_eq!(code, 1);
    assert!(
        err.contains("SHADENET_MAX_TEXT_BYTES=`lots`: expected a positive byte count"),
        "{err}"
    );
}

#[cfg(target_os = "linux")]
#[test]
fn shade_of_a_fifo_reads_nothing_and_ends() {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    let fifo = tmp("pipe.json");
    let _ = std::fs::remove_file(&fifo);
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
    assert!(made.success());
    let png = tmp("fifo.png");
    std::fs::write(&png, b"precious").unwrap();
    // A writer that feeds the FIFO whenever a reader has it open, counting the bytes it
    // got in: the command must not read it (a reader would block or read forever).
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let writer = {
        let (fifo, stop) = (fifo.clone(), stop.clone());
        std::thread::spawn(move || {
            const O_NONBLOCK: i32 = 0o4000;
            let mut written = 0usize;
            let chunk = vec![b' '; 4096];
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                if let Ok(mut f) = std::fs::OpenOptions::new()
                    .write(true)
                    .custom_flags(O_NONBLOCK)
                    .open(&fifo)
                {
                    while let Ok(n) = f.write(&chunk) {
                        written += n;
                        if written > 64 << 20 {
                            break;
                        }
                    }
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            written
        })
    };
    let (code, err) = run_limited(&["shade", fifo.to_str().unwrap(), "-o", png.to_str().unwrap()]);
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let written = writer.join().unwrap();
    assert_eq!(code, 1, "{err}");
    assert_eq!(
        err.trim(),
        format!(
            "error: {}: not a regular file (a FIFO); text input must be a regular file",
            fifo.display()
        )
    );
    assert_eq!(
        written, 0,
        "the command opened the FIFO and read {written} bytes"
    );
    assert_eq!(std::fs::read(&png).unwrap(), b"precious");
}

#[test]
fn absurd_thread_counts_are_refused() {
    let exr = tmp("threads.exr");
    std::fs::write(&exr, b"precious").unwrap();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    for n in ["100000", "0"] {
        let (code, err) = run_limited(&[
            "render",
            "--threads",
            n,
            "--res",
            "4x4",
            "-o",
            exr.to_str().unwrap(),
        ]);
        assert_eq!(code, 1, "{err}");
        assert_eq!(
            err.trim(),
            format!(
                "error: --threads {n}: expected 1 to {} (8 × the {cores} cores of this machine)",
                8 * cores
            )
        );
    }
    let net = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/networks/cells.json");
    let png = tmp("threads.png");
    let (code, err) = run_limited(&[
        "shade",
        net.to_str().unwrap(),
        "--threads",
        "100000",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--threads 100000: expected 1 to"), "{err}");
    assert_eq!(std::fs::read(&exr).unwrap(), b"precious");
    assert!(!png.exists());
}

/// A scene of two instances of one quad; `second` is the second instance's transform keys
/// and `camera` the camera's position.
fn two_instances(second: &str, camera: &str) -> String {
    format!(
        r#"
[camera]
position = {camera}
look_at = [0, 0, 0]
resolution = [8, 6]

[render]
spp = 1

[[lights]]
type = "point"
position = [2, 2, 4]
intensity = 10

[materials.m]
network = "{}"

[meshes.q]
type = "quad"

[[instances]]
mesh = "q"
material = "m"

[[instances]]
mesh = "q"
material = "m"
{second}
"#,
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("examples/scenes/materials/matte.json")
            .display()
    )
}

/// Scale typos and values beyond f32 (obvhs panicked on the first two inside its BVH
/// build) are exit code 1 with the key named, and the existing outputs stay as they were.
#[test]
fn out_of_range_transforms_and_cameras_name_the_key() {
    let nan_matrix = "matrix = [1, 0, 0, 0, 0, nan, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]";
    let inf_matrix = "matrix = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, inf, 0, 0, 0, 0, 1]";
    let cases = [
        ("scale = 1e20", "[0, 0, 5]", "instances[1].scale"),
        (
            "translate = [0, 1e39, 0]",
            "[0, 0, 5]",
            "instances[1].translate",
        ),
        (nan_matrix, "[0, 0, 5]", "instances[1].matrix"),
        (inf_matrix, "[0, 0, 5]", "instances[1].matrix"),
        ("", "[0, 0, 1e30]", "camera.position"),
    ];
    let exr = tmp("keep.exr");
    let png = tmp("keep.png");
    for (i, (second, camera, key)) in cases.iter().enumerate() {
        let scene = tmp(&format!("hostile{i}.toml"));
        std::fs::write(&scene, two_instances(second, camera)).unwrap();
        std::fs::write(&exr, b"precious").unwrap();
        std::fs::write(&png, b"precious too").unwrap();
        let (code, err) = run_limited(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            exr.to_str().unwrap(),
            "--png",
            png.to_str().unwrap(),
        ]);
        assert_eq!(code, 1, "{second} / camera {camera}: {err}");
        let line = err.lines().find(|l| l.starts_with("error: ")).unwrap_or("");
        assert!(
            line.starts_with(&format!("error: {}: `{key}`", scene.display())),
            "{second} / camera {camera}: the error should name `{key}`: {err}"
        );
        assert!(!err.contains("panicked"), "{err}");
        assert_eq!(std::fs::read(&exr).unwrap(), b"precious");
        assert_eq!(std::fs::read(&png).unwrap(), b"precious too");
    }
    // The same scene with ordinary values renders.
    let scene = tmp("ordinary.toml");
    std::fs::write(&scene, two_instances("scale = 1e3", "[0, 0, 5]")).unwrap();
    let (code, err) = run_limited(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(code, 0, "{err}");
}
