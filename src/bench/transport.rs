//! B6 (DESIGN §9), speed against error of the light-transport strategies: the physically
//! based example scene (`pbr.toml`, its closures) rendered with each `light_strategy` —
//! `mis`, `light` (light sampling only), `bsdf` (BSDF sampling only) — at a series of sample
//! counts, timed, and compared with a high-spp `mis` reference; then each strategy's error
//! at the time MIS took (log error interpolated against log time), the equal-time
//! comparison. It owns the suite and its tables; the rendering, relMSE, interpolation and
//! the error-against-time plot are `speed_error`'s (shared with B8), rows are `report`'s.

use super::report::{ErrorStats, Row};
use super::speed_error::{RELMSE_EPS, log_interp, prepare, relmse, render};
use super::{BenchOptions, SuiteResult};
use shadenet_graph::LightStrategy;
use std::fmt::Write as _;

/// The frame B6 renders (unless `--size`): a quarter of `pbr.toml`'s 480×270 area.
pub const B6_SIZE: (u32, u32) = (240, 135);
/// The frame of `--quick`.
pub const B6_QUICK_SIZE: (u32, u32) = (96, 54);
/// Samples per pixel of the `mis` reference (`--quick`: [`B6_QUICK_REFERENCE_SPP`]).
pub const B6_REFERENCE_SPP: u32 = 1024;
/// Samples per pixel of the `--quick` reference.
pub const B6_QUICK_REFERENCE_SPP: u32 = 128;

/// One measured render: strategy, spp, time, RMSE and relMSE over the RGB of the beauty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// The strategy.
    pub strategy: LightStrategy,
    /// Samples per pixel.
    pub spp: u32,
    /// Render time (median of the runs), seconds.
    pub time: f64,
    /// Root mean square error against the reference.
    pub rmse: f64,
    /// Mean of `(x − ref)² / (ref² + ε)` ([`RELMSE_EPS`]).
    pub relmse: f64,
}

/// The suite.
pub fn b6(opts: &BenchOptions) -> SuiteResult {
    let size = opts
        .size
        .unwrap_or(if opts.quick { B6_QUICK_SIZE } else { B6_SIZE });
    let (spps, ref_spp, reps): (Vec<u32>, u32, (usize, f64)) = if opts.quick {
        (vec![1, 2, 4, 8], B6_QUICK_REFERENCE_SPP, (1, 0.0))
    } else {
        (vec![1, 2, 4, 8, 16, 32, 64], B6_REFERENCE_SPP, (3, 1.0))
    };
    let path = opts.scenes.join("pbr.toml");
    let threads = rayon::current_num_threads();
    let title = format!(
        "light-transport strategies on pbr.toml ({}×{}): error against a {ref_spp}-spp MIS reference vs render time (JIT, {threads} thr)",
        size.0, size.1
    );
    let fail = |why: String| SuiteResult {
        name: "B6",
        title: title.clone(),
        rows: Vec::new(),
        extra: format!("\nNote: B6 did not run: {why}\n"),
    };
    let mut reference = match prepare(&path, size, |s| {
        s.settings.light_strategy = LightStrategy::Mis
    }) {
        Ok(r) => r,
        Err(e) => return fail(format!("{}: {e}", path.display())),
    };
    let (ref_time, ref_image) = render(&mut reference, ref_spp, (1, 0.0));
    let mut mis = Some(reference);
    let ref_image: Vec<f64> = ref_image.iter().map(|v| *v as f64).collect();
    let pixels = (size.0 * size.1) as u64;
    let mut rows = Vec::new();
    let mut points = Vec::new();
    for strategy in LightStrategy::ALL {
        // The reference's renderer renders `mis` too (compiled once).
        let prepared = match mis.take() {
            Some(r) if strategy == LightStrategy::Mis => Ok(r),
            _ => prepare(&path, size, |s| s.settings.light_strategy = strategy),
        };
        let mut r = match prepared {
            Ok(r) => r,
            Err(e) => return fail(format!("{} ({strategy}): {e}", path.display())),
        };
        for &spp in &spps {
            let (timing, image) = render(&mut r, spp, reps);
            let error = ErrorStats::measure(&image, &ref_image, 3);
            points.push(Point {
                strategy,
                spp,
                time: timing.median,
                rmse: error.rmse,
                relmse: relmse(&image, &ref_image),
            });
            rows.push(Row {
                suite: "B6",
                case: format!("pbr {}×{} {spp} spp", size.0, size.1),
                backend: "jit".into(),
                config: format!("light_strategy {strategy}, {threads} thr"),
                work: pixels * spp as u64,
                unit: "sample",
                time: timing,
                error: Some(error),
                ..Row::default()
            });
        }
    }
    let extra = format!(
        "\nReference: `mis` at {ref_spp} spp ({:.1} s). RMSE and relMSE (ε = {RELMSE_EPS}) over the beauty's RGB.\n\n{}\n{}",
        ref_time.median,
        measured_markdown(&points),
        equal_time_markdown(&points)
    );
    SuiteResult {
        name: "B6",
        title,
        rows,
        extra,
    }
}

/// Every measured point: strategy, spp, time, RMSE, relMSE.
pub fn measured_markdown(points: &[Point]) -> String {
    let mut s =
        String::from("| strategy | spp | time ms | RMSE | relMSE |\n|---|---|---|---|---|\n");
    for p in points {
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} | {:.4e} | {:.4e} |",
            p.strategy,
            p.spp,
            p.time * 1e3,
            p.rmse,
            p.relmse
        );
    }
    s
}

/// The points of one strategy as (time, `metric`), by time.
fn series(points: &[Point], s: LightStrategy, metric: fn(&Point) -> f64) -> Vec<(f64, f64)> {
    let mut v: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.strategy == s)
        .map(|p| (p.time, metric(p)))
        .collect();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    v
}

/// Error at equal time: at each MIS render's time, every strategy's RMSE and relMSE
/// interpolated (log–log) from its own renders; `*` marks an extrapolated value.
pub fn equal_time_markdown(points: &[Point]) -> String {
    let others = [LightStrategy::Light, LightStrategy::Bsdf];
    let mut s = String::from(
        "Error at equal time (at each `mis` render's time; `light` and `bsdf` interpolated log–log between their own renders, * = extrapolated beyond them):\n\n| mis spp | time ms | RMSE mis | RMSE light | RMSE bsdf | relMSE mis | relMSE light | relMSE bsdf | lowest RMSE |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    let rm: fn(&Point) -> f64 = |p| p.rmse;
    let rel: fn(&Point) -> f64 = |p| p.relmse;
    for m in points.iter().filter(|p| p.strategy == LightStrategy::Mis) {
        let at =
            |st: LightStrategy, f: fn(&Point) -> f64| log_interp(&series(points, st, f), m.time);
        let cell = |v: Option<(f64, bool)>| match v {
            Some((x, out)) => format!("{x:.4e}{}", if out { "*" } else { "" }),
            None => "—".into(),
        };
        let rmse: Vec<Option<(f64, bool)>> = others.iter().map(|st| at(*st, rm)).collect();
        let relm: Vec<Option<(f64, bool)>> = others.iter().map(|st| at(*st, rel)).collect();
        let mut best = (LightStrategy::Mis, m.rmse);
        for (st, v) in others.iter().zip(&rmse) {
            if let Some((x, _)) = v
                && *x < best.1
            {
                best = (*st, *x);
            }
        }
        let _ = writeln!(
            s,
            "| {} | {:.1} | {:.4e} | {} | {} | {:.4e} | {} | {} | {} |",
            m.spp,
            m.time * 1e3,
            m.rmse,
            cell(rmse[0]),
            cell(rmse[1]),
            m.relmse,
            cell(relm[0]),
            cell(relm[1]),
            best.0
        );
    }
    s
}
