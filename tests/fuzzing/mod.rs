//! The fuzzing engine of `tests/fuzz.rs`: a seeded random source, byte-level and
//! value-level mutators, and a runner that bounds every target by time, catches panics,
//! stops hangs and flags over-allocation, and leaves every failing input in the log and in
//! `target/fuzz-crashes/`.
//!
//! It runs on stable Rust without libFuzzer (cargo-fuzz needs a nightly toolchain, which CI
//! does not have): coverage guidance is traded for structure-aware mutation of our own seed
//! files. It owns no knowledge of the formats; the targets in `tests/fuzz.rs` do.
#![allow(dead_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The global allocator of the fuzz binary: the system allocator, recording the largest
/// single request since the last [`reset_largest`].
pub struct CountingAlloc;

static LARGEST: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is forwarded to the system allocator unchanged; the bookkeeping is one
// atomic maximum.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: the caller's contract is the system allocator's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        LARGEST.fetch_max(layout.size(), Ordering::Relaxed);
        // SAFETY: as `alloc`.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        LARGEST.fetch_max(new_size, Ordering::Relaxed);
        // SAFETY: as `dealloc` and `alloc`.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Forgets the largest allocation seen so far.
pub fn reset_largest() {
    LARGEST.store(0, Ordering::Relaxed);
}

/// The largest single allocation since [`reset_largest`], in bytes.
pub fn largest() -> usize {
    LARGEST.load(Ordering::Relaxed)
}

/// A small, fast, seeded random source (SplitMix64).
pub struct Rng(u64);

impl Rng {
    /// A source from a seed.
    pub fn new(seed: u64) -> Rng {
        Rng(seed)
    }

    /// The next 64 random bits.
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// A number in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// True with probability `1 / n`.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    /// One element of a non-empty slice.
    pub fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }
}

/// The numbers a value-level mutation puts in place of a number: the edges of f32, f64 and
/// the integer types, and the values that broke renders before (a scale of 1e20, a
/// translation of 1e39 that is finite in TOML and infinite in f32).
pub const HOSTILE_FLOATS: &[f64] = &[
    1e308,
    -1e308,
    1e-45,
    -1e-45,
    2147483648.0,
    -2147483648.0,
    0.0,
    -0.0,
    1e39,
    -1e39,
    1e20,
    1e30,
    3.4028235e38,
    1.1754944e-38,
    4294967296.0,
    65537.0,
    -1.0,
    0.5,
    1e-7,
];

/// The integers a value-level mutation puts in place of an integer.
pub const HOSTILE_INTS: &[i64] = &[
    0,
    -1,
    1,
    2,
    2147483647,
    2147483648,
    -2147483648,
    4294967295,
    4294967296,
    65536,
    65537,
    i64::MAX,
    i64::MIN,
    1 << 40,
];

/// A byte-level mutation of `input`: a few flips, inserts, deletions, duplications and
/// splices (from `others`), each chosen at random. The result stays under `max_len` bytes.
pub fn mutate_bytes(rng: &mut Rng, input: &[u8], others: &[Vec<u8>], max_len: usize) -> Vec<u8> {
    let mut v = input.to_vec();
    for _ in 0..1 + rng.below(4) {
        let n = v.len();
        match rng.below(7) {
            0 if n > 0 => {
                let i = rng.below(n);
                v[i] ^= 1 << rng.below(8);
            }
            1 => {
                let i = rng.below(n + 1);
                let b = *rng.pick(b"0123456789-.e+{}[]\",:=\n #/\\\x00\xff");
                v.insert(i, b);
            }
            2 if n > 0 => {
                let i = rng.below(n);
                let len = 1 + rng.below((n - i).min(16));
                v.drain(i..i + len);
            }
            3 if n > 0 => {
                let i = rng.below(n);
                let len = 1 + rng.below((n - i).min(64));
                let chunk: Vec<u8> = v[i..i + len].to_vec();
                let at = rng.below(v.len() + 1);
                v.splice(at..at, chunk);
            }
            4 if !others.is_empty() => {
                let o = rng.pick(others);
                if !o.is_empty() {
                    let i = rng.below(o.len());
                    let len = 1 + rng.below((o.len() - i).min(64));
                    let at = rng.below(v.len() + 1);
                    v.splice(at..at, o[i..i + len].iter().copied());
                }
            }
            5 if n > 0 => {
                // Replace a run of digits by a hostile number.
                let i = rng.below(n);
                if v[i].is_ascii_digit() {
                    let mut j = i;
                    while j < v.len() && (v[j].is_ascii_digit() || v[j] == b'.') {
                        j += 1;
                    }
                    let num = format!("{:e}", rng.pick(HOSTILE_FLOATS));
                    v.splice(i..j, num.into_bytes());
                }
            }
            _ if n > 0 => {
                let i = rng.below(n);
                v[i] = rng.next() as u8;
            }
            _ => v.push(rng.next() as u8),
        }
    }
    v.truncate(max_len);
    v
}

/// Makes a new input from a seed (the other seeds are there to splice from).
pub type Mutator = fn(&mut Rng, &[u8], &[Vec<u8>]) -> Vec<u8>;

/// What one target does: its name, its seeds, how it mutates and how it runs an input.
pub struct Target {
    /// Name, used for the environment filter, the log and the crash files.
    pub name: &'static str,
    /// The seed corpus: (name, bytes).
    pub seeds: Vec<(String, Vec<u8>)>,
    /// Makes a new input from a seed (the other seeds are there to splice from).
    pub mutate: Mutator,
    /// Runs one input; a panic is a finding, an error is a fine answer.
    pub exec: fn(&[u8]),
    /// The file extension of saved inputs.
    pub ext: &'static str,
}

/// What a run found.
#[derive(Debug, Default)]
pub struct Report {
    /// Inputs run.
    pub cases: u64,
    /// Findings: (what happened, where the input was saved).
    pub findings: Vec<(String, PathBuf)>,
}

/// Seconds each target runs: `SHADENET_FUZZ_SECS`, default `default`.
pub fn budget(default: f64) -> Duration {
    let secs = std::env::var("SHADENET_FUZZ_SECS")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .unwrap_or(default);
    Duration::from_secs_f64(secs)
}

/// The seed CI fuzzes from when `SHADENET_FUZZ_SEED` is unset: fixed, so that a test run
/// explores the same inputs on every machine (a slower machine a shorter prefix of them) and
/// a submission cannot fail on a finding its change did not cause. Long local runs explore
/// new inputs with `SHADENET_FUZZ_SEED=clock`.
pub const CI_SEED: u64 = 0x5eed_5ade_4e70_0001;

/// The random seed: `SHADENET_FUZZ_SEED` (a number, or `clock` for one from the clock;
/// printed, so a run can be repeated), else [`CI_SEED`].
pub fn seed() -> u64 {
    match std::env::var("SHADENET_FUZZ_SEED").ok().as_deref() {
        None | Some("") => CI_SEED,
        Some("clock") => std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(1, |d| d.as_nanos() as u64),
        Some(s) => s
            .parse()
            .unwrap_or_else(|_| panic!("SHADENET_FUZZ_SEED={s}: expected a number or `clock`")),
    }
}

/// The largest single allocation an input may cause (`SHADENET_FUZZ_ALLOC_MB`, default 512
/// MiB): inputs are a few kilobytes and renders tiny, so more is an over-allocation.
pub fn alloc_limit() -> usize {
    std::env::var("SHADENET_FUZZ_ALLOC_MB")
        .ok()
        .and_then(|s| s.parse::<usize>().ok())
        .unwrap_or(512)
        << 20
}

/// How long one input may run before it counts as a hang (`SHADENET_FUZZ_CASE_SECS`,
/// default 120 s: a debug build renders tiny images in well under a second).
pub fn case_limit() -> Duration {
    Duration::from_secs(
        std::env::var("SHADENET_FUZZ_CASE_SECS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(120),
    )
}

/// Where failing inputs are saved.
pub fn crash_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/fuzz-crashes")
}

/// The input as the log shows it: text escaped as a Rust string, at most 4 KiB of it.
pub fn show(input: &[u8]) -> String {
    let text = String::from_utf8_lossy(&input[..input.len().min(4096)]);
    let more = if input.len() > 4096 {
        format!(" … ({} bytes in all)", input.len())
    } else {
        String::new()
    };
    format!("{text:?}{more}")
}

/// Saves a failing input and prints it; returns the path.
pub fn save(name: &str, ext: &str, input: &[u8], what: &str) -> PathBuf {
    let dir = crash_dir();
    let _ = std::fs::create_dir_all(&dir);
    let hash = input.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ *b as u64).wrapping_mul(0x100_0000_01b3)
    });
    let path = dir.join(format!("{name}-{hash:016x}.{ext}"));
    let _ = std::fs::write(&path, input);
    eprintln!(
        "fuzz {name}: {what}\n  input saved as {}\n  input: {}",
        path.display(),
        show(input)
    );
    path
}

/// The message of the last panic, recorded by the hook [`run`] installs.
static LAST_PANIC: Mutex<String> = Mutex::new(String::new());

/// Records each panic's message for [`run_one`] instead of printing it.
pub fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let msg = match info.payload().downcast_ref::<&str>() {
            Some(s) => s.to_string(),
            None => info
                .payload()
                .downcast_ref::<String>()
                .cloned()
                .unwrap_or_else(|| "(no message)".into()),
        };
        let at = info
            .location()
            .map_or(String::new(), |l| format!(" at {}:{}", l.file(), l.line()));
        if let Ok(mut m) = LAST_PANIC.lock() {
            *m = format!("{msg}{at}");
        }
    }));
}

/// One input under the watchdog: the case it is running and since when.
type Current = Arc<Mutex<Option<(Instant, Vec<u8>)>>>;

/// Starts the watchdog: an input running past [`case_limit`] is saved, printed, and the
/// process exits with a failure (a hung thread cannot be stopped from outside).
fn watchdog(target: &'static str, ext: &'static str, current: Current) {
    std::thread::spawn(move || {
        let limit = case_limit();
        loop {
            std::thread::sleep(Duration::from_millis(500));
            if Arc::strong_count(&current) == 1 {
                return; // the run is over
            }
            let Ok(guard) = current.lock() else { return };
            if let Some((start, input)) = guard.as_ref()
                && start.elapsed() > limit
            {
                save(
                    target,
                    ext,
                    input,
                    &format!("hang: one input ran over {limit:?}"),
                );
                std::process::exit(3);
            }
        }
    });
}

/// Runs one input: a panic or an over-allocation is a finding (its text).
pub fn run_one(exec: fn(&[u8]), input: &[u8]) -> Option<String> {
    reset_largest();
    let result = std::panic::catch_unwind(AssertUnwindSafe(|| exec(input)));
    if result.is_err() {
        let msg = LAST_PANIC.lock().map(|m| m.clone()).unwrap_or_default();
        return Some(format!("panic: {msg}"));
    }
    let big = largest();
    if big > alloc_limit() {
        return Some(format!(
            "over-allocation: one allocation of {big} bytes (limit {} bytes)",
            alloc_limit()
        ));
    }
    None
}

/// Runs a target for `budget`: every seed once, then mutated seeds until time is up.
pub fn run(target: &Target, budget: Duration, seed: u64) -> Report {
    install_panic_hook();
    let current: Current = Arc::new(Mutex::new(None));
    watchdog(target.name, target.ext, current.clone());
    let mut rng = Rng::new(seed);
    let others: Vec<Vec<u8>> = target.seeds.iter().map(|s| s.1.clone()).collect();
    let mut report = Report::default();
    let start = Instant::now();
    let mut i = 0usize;
    while i < others.len() || start.elapsed() < budget {
        let input = if i < others.len() {
            others[i].clone()
        } else {
            let base = rng.pick(&others).clone();
            (target.mutate)(&mut rng, &base, &others)
        };
        i += 1;
        if let Ok(mut c) = current.lock() {
            *c = Some((Instant::now(), input.clone()));
        }
        let finding = run_one(target.exec, &input);
        if let Ok(mut c) = current.lock() {
            *c = None;
        }
        report.cases += 1;
        if let Some(what) = finding {
            let path = save(target.name, target.ext, &input, &what);
            report.findings.push((what, path));
            if report.findings.len() >= 5 {
                break;
            }
        }
    }
    let _ = std::panic::take_hook();
    report
}
