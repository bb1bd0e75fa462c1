//! B7, the peer suite (issue 23): the three workloads of the comparison with OSL's
//! `testshade` — the multiplication tree at levels 1 and 10 and one `fractal` (fBm) node —
//! shaded through the code path of `shadenet shade --backend jit-batch --threads 2`
//! ([`crate::shade::shade_grid_into`] with the batch entry on a 2-thread pool, the output
//! buffer kept across frames as testshade keeps its own), the median per frame over at least
//! ten frames after one warm-up frame, printed beside OSL's figures
//! as quoted in the issue (measured on another machine: not reproducible here).

use super::report::{Row, Timing, time};
use super::workloads::tree_program;
use super::{BenchOptions, SuiteResult, actual, pool};
use crate::shade::{grid_env, shade_grid_into};
use shadenet_graph::ir::{Program, Space};
use shadenet_graph::opt::Specialization;
use shadenet_graph::{NodeLibrary, compile_json};
use shadenet_jit::{JitBackend, JitOptions};
use shadenet_runtime::Backend;

/// `examples/networks/fbm.json`: one `fractal` node of object-space P (scale 3, 6 octaves,
/// lacunarity 2.1, gain 0.55); B7 shades it unfiltered ([`fbm_unfiltered`]).
const FBM_NETWORK: &str = include_str!("../../examples/networks/fbm.json");

/// Threads, as in the quoted runs.
const THREADS: usize = 2;

/// The quoted figures (issue 23, one 2-core AMD EPYC with AVX-512, 640×480, 2 threads):
/// work, ours then (one frame of `shadenet shade`), OSL 1.13.9 scalar, OSL batched 16-wide.
const QUOTED: [(&str, &str, &str, &str); 3] = [
    ("B1 tree level 1", "3.3 ms", "4.3–5.3 ms", "1.0 ms"),
    ("B1 tree level 10", "4.6 ms", "7.7 ms", "1.3–1.4 ms"),
    (
        "fBm (fractal of object P)",
        "31.5 ms",
        "43–47 ms",
        "32.6 ms",
    ),
];

/// [`FBM_NETWORK`] with its fractal unfiltered (`filter = 0`), as OSL's quoted `fBm` is: both
/// sides compute the same six octaves (filtered, the finest octaves fade at this grid).
fn fbm_unfiltered() -> String {
    let mut v: serde_json::Value =
        serde_json::from_str(FBM_NETWORK).expect("examples/networks/fbm.json is JSON");
    if let Some(nodes) = v["nodes"].as_array_mut() {
        for n in nodes.iter_mut().filter(|n| n["type"] == "fractal") {
            n["inputs"]["filter"] = 0.into();
        }
    }
    v.to_string()
}

/// The three workloads: (case, linked program).
fn workloads() -> Vec<(&'static str, Program)> {
    let fbm = compile_json(&fbm_unfiltered(), &NodeLibrary::standard())
        .expect("examples/networks/fbm.json links")
        .program;
    vec![
        (QUOTED[0].0, tree_program(1, Space::World)),
        (QUOTED[1].0, tree_program(10, Space::World)),
        (QUOTED[2].0, fbm),
    ]
}

/// Runs B7.
pub fn b7(opts: &BenchOptions) -> SuiteResult {
    let (w, h) = opts.size();
    let frames = if opts.quick { 3 } else { 10 };
    let threads = pool(THREADS);
    // `shadenet shade`'s defaults: the JIT with both entries, the default specialization
    // with parameters baked; these networks read no light.
    let backend = JitBackend::with_options(JitOptions {
        log_fallback: false,
        ..JitOptions::default()
    });
    let spec = Specialization {
        bake: true,
        ..Specialization::default()
    };
    let env = grid_env(&[]);
    let mut rows = Vec::new();
    let mut medians = Vec::new();
    for (case, program) in workloads() {
        let m = backend
            .compile(&program, &spec)
            .expect("the B7 networks compile");
        // The output buffer is kept from frame to frame, as testshade's is: the warm-up
        // frame allocates it.
        let mut data = Vec::new();
        let mut frame = || {
            threads.install(|| {
                shade_grid_into(&*m, &env, (w, h), spec.components, true, &mut data);
            });
        };
        frame(); // warm-up
        let t: Timing = time(frames, 0.0, frame);
        medians.push(t.median);
        rows.push(Row {
            suite: "B7",
            case: case.to_string(),
            backend: actual("jit", &*m),
            config: format!("batch, {THREADS} threads, median of {} frames", t.runs),
            work: u64::from(w) * u64::from(h),
            unit: "fragments",
            time: t,
            vs_interp: None,
            vs_native: None,
            error: None,
            split: None,
        });
    }
    SuiteResult {
        name: "B7",
        title: format!(
            "peers: `shade --backend jit-batch --threads {THREADS}` per frame, {w}×{h}, beside OSL's testshade (quoted)"
        ),
        rows,
        extra: quoted_beside(&medians, (w, h)),
    }
}

/// Our medians beside the quoted figures.
fn quoted_beside(medians: &[f64], (w, h): (u32, u32)) -> String {
    let mut s = format!(
        "\nOurs (this machine, {w}×{h}{}) beside figures quoted in issue 23 from another machine (2-core AMD EPYC, AVX-512, 640×480, 2 threads; OSL 1.13.9 with LLVM 15, `testshade -t 2`, per frame after the first). Quoted figures are not reproducible here.\n\n\
         | work | ours: median per frame | quoted: ours then | quoted: OSL scalar | quoted: OSL batched (16-wide AVX-512) |\n|---|---|---|---|---|\n",
        if (w, h) != (640, 480) {
            ", quick size: scale by the pixel count to compare"
        } else {
            ""
        }
    );
    for ((work, then, scalar, batched), t) in QUOTED.iter().zip(medians) {
        s.push_str(&format!(
            "| {work} | {:.2} ms | {then} | {scalar} | {batched} |\n",
            t * 1e3
        ));
    }
    s
}
