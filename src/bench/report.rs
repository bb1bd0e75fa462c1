//! The results of `shadenet bench`: rows, the printed tables, CSV, SVG plots and the
//! markdown summary.

use shadenet_runtime::BatchTimes;
use std::fmt::Write as _;
use std::time::Instant;

/// Error of a result against the f64 interpreter, over the values the film (or the output
/// buffer) stores: the reference is rounded to f32 and guarded (non-finite → 0) first.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorStats {
    /// Largest absolute difference of any float.
    pub max_abs: f64,
    /// Root mean square difference over all floats.
    pub rmse: f64,
    /// Pixels with some float differing by more than [`DIFF_TOL`] × max(1, |reference|).
    pub differing: u64,
    /// Pixels compared.
    pub pixels: u64,
}

/// The relative tolerance of "differing pixel": 2⁻¹⁰, about a tenth of an 8-bit step.
pub const DIFF_TOL: f64 = 1.0 / 1024.0;

impl ErrorStats {
    /// Compares `got` with `reference`, `stride` floats per pixel.
    pub fn measure(got: &[f32], reference: &[f64], stride: usize) -> ErrorStats {
        assert_eq!(got.len(), reference.len(), "same number of values");
        let mut e = ErrorStats::default();
        let mut sq = 0.0f64;
        for (g, r) in got
            .chunks(stride.max(1))
            .zip(reference.chunks(stride.max(1)))
        {
            let mut differs = false;
            for (&g, &r) in g.iter().zip(r) {
                let r32 = r as f32;
                let r = if r32.is_finite() { r32 as f64 } else { 0.0 };
                let d = (g as f64 - r).abs();
                e.max_abs = e.max_abs.max(d);
                sq += d * d;
                differs |= d > DIFF_TOL * r.abs().max(1.0);
            }
            e.differing += differs as u64;
            e.pixels += 1;
        }
        e.rmse = (sq / got.len().max(1) as f64).sqrt();
        e
    }
}

/// Median, minimum and maximum of repeated runs, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timing {
    /// Median run.
    pub median: f64,
    /// Fastest run.
    pub min: f64,
    /// Slowest run.
    pub max: f64,
    /// Runs.
    pub runs: usize,
}

/// Times `f` at least `reps` times (at least once), repeating fast runs until `budget`
/// seconds have passed (at most 25 runs).
pub fn time(reps: usize, budget: f64, mut f: impl FnMut()) -> Timing {
    let mut ts = Vec::new();
    let start = Instant::now();
    while ts.len() < reps.max(1) || (start.elapsed().as_secs_f64() < budget && ts.len() < 25) {
        let s = Instant::now();
        f();
        ts.push(s.elapsed().as_secs_f64());
    }
    Timing::of(ts).expect("at least one run")
}

impl Timing {
    /// The median, extremes and count of some run times (seconds); `None` for no runs.
    pub fn of(mut ts: Vec<f64>) -> Option<Timing> {
        ts.sort_by(f64::total_cmp);
        let n = ts.len();
        let median = match n {
            0 => return None,
            _ if n % 2 == 1 => ts[n / 2],
            _ => (ts[n / 2 - 1] + ts[n / 2]) / 2.0,
        };
        Some(Timing {
            median,
            min: ts[0],
            max: ts[n - 1],
            runs: n,
        })
    }
}

/// One measured row.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Row {
    /// Suite (`B1` …).
    pub suite: &'static str,
    /// What is measured (rows with the same case are compared with each other).
    pub case: String,
    /// The back end that actually ran (a JIT that fell back says so).
    pub backend: String,
    /// Configuration: CSE, entry (scalar/batch), threads.
    pub config: String,
    /// Work size (fragments, or nodes for preprocessing).
    pub work: u64,
    /// Unit of `work`.
    pub unit: &'static str,
    /// The timing.
    pub time: Timing,
    /// Speed-up against the interpreter row of the same case (interp time / this time).
    pub vs_interp: Option<f64>,
    /// Speed relative to the native reference row of the same case (native time / this
    /// time: 1 is as fast as rustc's code).
    pub vs_native: Option<f64>,
    /// Error against the f64 interpreter (none where nothing is output: preprocessing).
    pub error: Option<ErrorStats>,
    /// Where the shading time of a batch back end (the GPU) went: upload, kernels, host
    /// steps, readback, and passes dispatched, from `Material::shade_many` (of the median
    /// run; a render's sums over its batches and threads).
    pub split: Option<BatchTimes>,
}

impl Row {
    /// Work per second.
    pub fn throughput(&self) -> f64 {
        self.work as f64 / self.time.median.max(1e-12)
    }
}

/// Fills in the ratio columns: per suite and case, against the row whose back end is
/// `interp` (CSE off where there are both) and the row whose back end is `native`.
pub fn fill_ratios(rows: &mut [Row]) {
    let refs: Vec<(Option<f64>, Option<f64>)> = rows
        .iter()
        .map(|r| {
            let key = format!("{}/{}", r.suite, r.case);
            let find = |b: &str| {
                rows.iter()
                    .filter(|q| format!("{}/{}", q.suite, q.case) == key && q.backend == b)
                    .map(|q| q.time.median)
                    .next()
            };
            (find("interp"), find("native (rustc)"))
        })
        .collect();
    for (r, (i, n)) in rows.iter_mut().zip(refs) {
        r.vs_interp = i.map(|t| t / r.time.median.max(1e-12));
        r.vs_native = n.map(|t| t / r.time.median.max(1e-12));
    }
}

fn ms(s: f64) -> String {
    format!("{:.3}", s * 1e3)
}

fn opt(v: Option<f64>, f: impl Fn(f64) -> String) -> String {
    v.map(f).unwrap_or_else(|| "—".into())
}

/// The column names of tables and CSV.
pub const COLUMNS: [&str; 21] = [
    "suite",
    "case",
    "backend",
    "config",
    "work",
    "unit",
    "median_ms",
    "min_ms",
    "max_ms",
    "runs",
    "throughput_per_s",
    "vs_interp",
    "vs_native",
    "max_abs_err",
    "rmse",
    "differing_pixels",
    "upload_ms",
    "kernels_ms",
    "host_ms",
    "readback_ms",
    "gpu_passes",
];

fn cells(r: &Row) -> Vec<String> {
    vec![
        r.suite.to_string(),
        r.case.clone(),
        r.backend.clone(),
        r.config.clone(),
        r.work.to_string(),
        r.unit.to_string(),
        ms(r.time.median),
        ms(r.time.min),
        ms(r.time.max),
        r.time.runs.to_string(),
        format!("{:.4e}", r.throughput()),
        opt(r.vs_interp, |v| format!("{v:.2}")),
        opt(r.vs_native, |v| format!("{v:.2}")),
        opt(r.error.map(|e| e.max_abs), |v| format!("{v:.3e}")),
        opt(r.error.map(|e| e.rmse), |v| format!("{v:.3e}")),
        r.error
            .map(|e| format!("{}/{}", e.differing, e.pixels))
            .unwrap_or_else(|| "—".into()),
        opt(r.split.map(|t| t.upload.as_secs_f64()), ms),
        opt(r.split.map(|t| t.kernels.as_secs_f64()), ms),
        opt(r.split.map(|t| t.host.as_secs_f64()), ms),
        opt(r.split.map(|t| t.readback.as_secs_f64()), ms),
        r.split
            .map(|t| t.passes.to_string())
            .unwrap_or_else(|| "—".into()),
    ]
}

/// A markdown table of rows; with a column of the GPU time split (upload / kernels / host /
/// readback ms, passes) when some row has one.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::new();
    let split = rows.iter().any(|r| r.split.is_some());
    let mut head = vec![
        "case",
        "back end",
        "config",
        "work",
        "median ms (min–max, runs)",
        "throughput /s",
        "× interp",
        "× native",
        "max abs err",
        "RMSE",
        "differing px",
    ];
    if split {
        head.push("GPU split ms: upload / kernels / host / readback (passes)");
    }
    let _ = writeln!(s, "| {} |", head.join(" | "));
    let _ = writeln!(s, "|{}", "---|".repeat(head.len()));
    for r in rows {
        let c = cells(r);
        let _ = write!(
            s,
            "| {} | {} | {} | {} {} | {} ({}–{}, {}) | {} | {} | {} | {} | {} | {} |",
            c[1],
            c[2],
            c[3],
            c[4],
            c[5],
            c[6],
            c[7],
            c[8],
            c[9],
            c[10],
            c[11],
            c[12],
            c[13],
            c[14],
            c[15]
        );
        if split {
            let _ = write!(
                s,
                " {} |",
                if r.split.is_some() {
                    format!("{} / {} / {} / {} ({})", c[16], c[17], c[18], c[19], c[20])
                } else {
                    "—".into()
                }
            );
        }
        s.push('\n');
    }
    s
}

/// CSV (RFC 4180: every field quoted) with a header line.
pub fn csv(rows: &[Row]) -> String {
    let q = |s: &str| format!("\"{}\"", s.replace('"', "\"\""));
    let mut s = COLUMNS.map(q).join(",");
    s.push('\n');
    for r in rows {
        let mut c = cells(r);
        for v in c.iter_mut().skip(11) {
            if v == "—" {
                v.clear();
            }
        }
        s.push_str(&c.iter().map(|v| q(v)).collect::<Vec<_>>().join(","));
        s.push('\n');
    }
    s
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// A horizontal bar chart of the rows' median times (log scale), one bar per row, grouped by
/// case, with min–max whiskers: hand-written SVG.
pub fn svg(title: &str, rows: &[Row]) -> String {
    let bar = 16.0;
    let left = 430.0;
    let width = 1000.0;
    let plot = width - left - 90.0;
    let top = 40.0;
    let height = top + rows.len() as f64 * (bar + 4.0) + 40.0;
    // Only finite, positive times set the axis (an empty suite still gets a valid one).
    let times = || {
        rows.iter()
            .flat_map(|r| [r.time.min, r.time.max])
            .filter(|t| t.is_finite() && *t > 0.0)
    };
    let lo = times().fold(f64::INFINITY, f64::min);
    let lo = if lo.is_finite() { lo.max(1e-7) } else { 1e-3 };
    let hi = times().fold(lo * 10.0, f64::max);
    let (l0, l1) = (lo.log10().floor(), hi.log10().ceil());
    let x = |t: f64| left + (t.max(lo).log10() - l0) / (l1 - l0) * plot;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" font-family=\"sans-serif\" font-size=\"11\">"
    );
    let _ = writeln!(
        s,
        "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"10\" y=\"20\" font-size=\"14\">{} — median time, log scale (whiskers: min–max)</text>",
        esc(title)
    );
    let mut d = l0 as i32;
    while d as f64 <= l1 {
        let t = 10f64.powi(d);
        let xx = x(t);
        let label = if t >= 1.0 {
            format!("{t} s")
        } else {
            format!("{} ms", t * 1e3)
        };
        let _ = writeln!(
            s,
            "<line x1=\"{xx:.1}\" y1=\"{top}\" x2=\"{xx:.1}\" y2=\"{:.1}\" stroke=\"#ccc\"/><text x=\"{xx:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
            height - 30.0,
            height - 15.0,
            esc(&label)
        );
        d += 1;
    }
    let colour = |b: &str| match b {
        "interp" => "#d62728",
        "native (rustc)" => "#2ca02c",
        b if b.starts_with("jit") => "#1f77b4",
        b if b.starts_with("gpu") => "#9467bd",
        _ => "#ff7f0e",
    };
    for (i, r) in rows.iter().enumerate() {
        let y = top + i as f64 * (bar + 4.0);
        let label = format!("{} · {} · {}", r.case, r.backend, r.config);
        let _ = writeln!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            left - 6.0,
            y + bar - 4.0,
            esc(&label)
        );
        let _ = writeln!(
            s,
            "<rect x=\"{left}\" y=\"{y:.1}\" width=\"{:.1}\" height=\"{bar}\" fill=\"{}\"/>",
            (x(r.time.median) - left).max(1.0),
            colour(&r.backend)
        );
        let ym = y + bar / 2.0;
        let _ = writeln!(
            s,
            "<line x1=\"{:.1}\" y1=\"{ym:.1}\" x2=\"{:.1}\" y2=\"{ym:.1}\" stroke=\"black\"/><text x=\"{:.1}\" y=\"{:.1}\">{} ms</text>",
            x(r.time.min),
            x(r.time.max),
            x(r.time.max) + 4.0,
            y + bar - 4.0,
            ms(r.time.median)
        );
    }
    s.push_str("</svg>\n");
    s
}
