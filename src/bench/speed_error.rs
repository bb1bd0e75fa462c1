//! Speed against error, shared by the suites that measure it (B6: light-transport
//! strategies, B8: texture filtering): a scene loaded, edited and compiled for the JIT, timed
//! renders returning the beauty's RGB, relMSE, log–log interpolation of error against time,
//! and the error-against-time plot. The suites own their variants and tables.

use super::report::{Row, Timing, time};
use super::{jit, render::RuntimeShaders};
use shadenet_graph::ir::Program;
use shadenet_tracer::Renderer;
use shadenet_tracer::scene::{self, Scene};
use std::fmt::Write as _;
use std::path::Path;

/// The `ε` of relMSE, `(x − ref)² / (ref² + ε)`: keeps black pixels from dominating.
pub const RELMSE_EPS: f64 = 1e-2;

/// The RGB floats of a beauty layer of `stride` channels.
pub(crate) fn rgb(data: &[f32], stride: usize) -> Vec<f32> {
    data.chunks(stride.max(1))
        .flat_map(|p| p.iter().take(3).copied())
        .collect()
}

/// relMSE of `got` against `reference` ([`RELMSE_EPS`]).
pub fn relmse(got: &[f32], reference: &[f64]) -> f64 {
    let n = got.len().max(1) as f64;
    got.iter()
        .zip(reference)
        .map(|(&g, &r)| {
            let d = g as f64 - r;
            d * d / (r * r + RELMSE_EPS)
        })
        .sum::<f64>()
        / n
}

/// `log y` at `log x`, piecewise linear through `points` (x ascending, all positive);
/// beyond the ends along the end segment. `None` with fewer than two points. The flag says
/// whether `x` lay outside the measured range (extrapolated).
pub fn log_interp(points: &[(f64, f64)], x: f64) -> Option<(f64, bool)> {
    let p: Vec<(f64, f64)> = points
        .iter()
        .filter(|(a, b)| *a > 0.0 && *b > 0.0 && a.is_finite() && b.is_finite())
        .map(|(a, b)| (a.ln(), b.ln()))
        .collect();
    if p.len() < 2 || x.is_nan() || x <= 0.0 {
        return None;
    }
    let lx = x.ln();
    let outside = lx < p[0].0 || lx > p[p.len() - 1].0;
    let i = p
        .windows(2)
        .position(|w| lx <= w[1].0)
        .unwrap_or(p.len() - 2);
    let (a, b) = (p[i], p[i + 1]);
    let t = if b.0 > a.0 {
        (lx - a.0) / (b.0 - a.0)
    } else {
        0.0
    };
    Some(((a.1 + t * (b.1 - a.1)).exp(), outside))
}

/// The scene at `path`, its frame set to `size`, changed by `edit` (a light strategy, material
/// overrides), compiled for the JIT with the scene's light strategy; `Err` says why (the
/// MaterialX libraries missing, a bad override).
pub(crate) fn prepare(
    path: &Path,
    size: (u32, u32),
    edit: impl FnOnce(&mut Scene),
) -> Result<Renderer, String> {
    let mut s: Scene = scene::load(path).map_err(|e| shadenet_graph::error_chain(&e))?;
    s.camera.width = size.0;
    s.camera.height = size.1;
    edit(&mut s);
    crate::scene_lights::compile(&mut s, true, true)
        .map_err(|e| shadenet_graph::error_chain(&e))?;
    let strategy = s.settings.light_strategy;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let programs = s
        .materials
        .iter()
        .map(|m| {
            crate::render::compile_material(m, crate::render::Files::Disk, &dir, None, strategy)
                .map(|c| c.program)
                .map_err(|e| shadenet_graph::error_chain(&e))
        })
        .collect::<Result<Vec<Program>, String>>()?;
    let backend = RuntimeShaders::new(Box::new(jit(false)));
    Renderer::new(s, programs, &backend).map_err(|e| e.to_string())
}

/// Renders at `spp` `reps` times; the timing and the beauty's RGB (the renders are
/// deterministic: every run gives the same image).
pub(crate) fn render(r: &mut Renderer, spp: u32, reps: (usize, f64)) -> (Timing, Vec<f32>) {
    r.set_spp(spp);
    let mut image = Vec::new();
    let timing = time(reps.0, reps.1, || {
        let (film, _) = r.render(&|_, _| {});
        if let Some(l) = film.layers.first() {
            image = rgb(&l.data, l.channels.len());
        }
    });
    (timing, image)
}

/// The plot: RMSE against render time, log–log, one polyline per series, from the rows
/// (the series is `config` up to its first comma: B6's series, B8's filtering):
/// hand-written SVG.
pub fn svg(title: &str, rows: &[Row]) -> String {
    let (w, h, left, top, right, bottom) = (760.0, 480.0, 80.0, 40.0, 150.0, 50.0);
    let pts: Vec<(String, f64, f64)> = rows
        .iter()
        .filter_map(|r| {
            let e = r.error?.rmse;
            let series = r.config.split(',').next().unwrap_or("").to_string();
            (r.time.median > 0.0 && e > 0.0 && e.is_finite()).then_some((series, r.time.median, e))
        })
        .collect();
    let range = |f: fn(&(String, f64, f64)) -> f64| {
        let lo = pts.iter().map(f).fold(f64::INFINITY, f64::min);
        let hi = pts.iter().map(f).fold(f64::NEG_INFINITY, f64::max);
        if lo.is_finite() && hi.is_finite() {
            (
                lo.log10().floor(),
                hi.log10().ceil().max(lo.log10().floor() + 1.0),
            )
        } else {
            (-3.0, 0.0)
        }
    };
    let (tx0, tx1) = range(|p| p.1);
    let (ey0, ey1) = range(|p| p.2);
    let pw = w - left - right;
    let ph = h - top - bottom;
    let x = |t: f64| left + (t.log10() - tx0) / (tx1 - tx0) * pw;
    let y = |e: f64| top + (ey1 - e.log10()) / (ey1 - ey0) * ph;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"10\" y=\"20\" font-size=\"13\">{} — RMSE vs render time (log–log)</text>",
        esc(title)
    );
    for d in (tx0 as i32)..=(tx1 as i32) {
        let xx = x(10f64.powi(d));
        let _ = writeln!(
            s,
            "<line x1=\"{xx:.1}\" y1=\"{top}\" x2=\"{xx:.1}\" y2=\"{:.1}\" stroke=\"#ccc\"/><text x=\"{xx:.1}\" y=\"{:.1}\" text-anchor=\"middle\">1e{d} s</text>",
            top + ph,
            top + ph + 16.0
        );
    }
    for d in (ey0 as i32)..=(ey1 as i32) {
        let yy = y(10f64.powi(d));
        let _ = writeln!(
            s,
            "<line x1=\"{left}\" y1=\"{yy:.1}\" x2=\"{:.1}\" y2=\"{yy:.1}\" stroke=\"#ccc\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">1e{d}</text>",
            left + pw,
            left - 6.0,
            yy + 4.0
        );
    }
    let colours = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"];
    let mut names: Vec<&str> = Vec::new();
    for p in &pts {
        if !names.contains(&p.0.as_str()) {
            names.push(&p.0);
        }
    }
    for (i, name) in names.iter().enumerate() {
        let c = colours[i % colours.len()];
        let mut line: Vec<(f64, f64)> = pts
            .iter()
            .filter(|p| p.0 == *name)
            .map(|p| (x(p.1), y(p.2)))
            .collect();
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        let d: Vec<String> = line.iter().map(|(a, b)| format!("{a:.1},{b:.1}")).collect();
        let _ = writeln!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{c}\" stroke-width=\"2\"/>",
            d.join(" ")
        );
        for (a, b) in &line {
            let _ = writeln!(
                s,
                "<circle cx=\"{a:.1}\" cy=\"{b:.1}\" r=\"3\" fill=\"{c}\"/>"
            );
        }
        let ly = top + 16.0 * (i as f64 + 1.0);
        let _ = writeln!(
            s,
            "<line x1=\"{:.1}\" y1=\"{ly:.1}\" x2=\"{:.1}\" y2=\"{ly:.1}\" stroke=\"{c}\" stroke-width=\"2\"/><text x=\"{:.1}\" y=\"{:.1}\">{}</text>",
            left + pw + 10.0,
            left + pw + 30.0,
            left + pw + 34.0,
            ly + 4.0,
            esc(name)
        );
    }
    s.push_str("</svg>\n");
    s
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::report::ErrorStats;

    #[test]
    fn log_interp_is_exact_on_power_laws_and_flags_extrapolation() {
        // e = 1/√t: a straight line in log–log.
        let pts: Vec<(f64, f64)> = [1.0f64, 4.0, 16.0]
            .iter()
            .map(|t| (*t, 1.0 / t.sqrt()))
            .collect();
        let (v, out) = log_interp(&pts, 2.0).unwrap();
        assert!((v - 1.0 / 2f64.sqrt()).abs() < 1e-12 && !out);
        let (v, out) = log_interp(&pts, 64.0).unwrap();
        assert!((v - 0.125).abs() < 1e-12 && out);
        assert!(log_interp(&pts[..1], 2.0).is_none());
        assert!(log_interp(&pts, 0.0).is_none());
    }

    #[test]
    fn relmse_weights_errors_by_the_reference() {
        assert_eq!(relmse(&[1.0, 0.0], &[1.0, 0.0]), 0.0);
        let v = relmse(&[2.0], &[1.0]);
        assert!((v - 1.0 / 1.01).abs() < 1e-12);
    }

    #[test]
    fn rgb_drops_the_channels_after_the_third() {
        assert_eq!(
            rgb(&[1.0, 2.0, 3.0, 9.0, 4.0, 5.0, 6.0, 9.0], 4),
            [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
        );
    }

    #[test]
    fn the_plot_has_one_line_per_series() {
        let row = |st: &str, t: f64, e: f64| Row {
            config: format!("light_strategy {st}, 2 thr"),
            time: Timing {
                median: t,
                min: t,
                max: t,
                runs: 1,
            },
            error: Some(ErrorStats {
                rmse: e,
                ..ErrorStats::default()
            }),
            ..Row::default()
        };
        let rows = [
            row("mis", 0.1, 0.1),
            row("mis", 0.2, 0.07),
            row("light", 0.1, 0.2),
            row("light", 0.2, 0.14),
        ];
        let s = svg("B6", &rows);
        assert!(s.starts_with("<svg") && s.trim_end().ends_with("</svg>"));
        assert_eq!(s.matches("<polyline").count(), 2);
        assert_eq!(s.matches("<circle").count(), 4);
        assert!(s.contains("light_strategy mis") && s.contains("light_strategy light"));
    }
}
