//! B8 (issue 16), speed against error of texture filtering: `texture_plane.toml` (an unlit
//! ground at a grazing angle, the filtered checker on the left, the mipmapped image
//! `textures/grid.png` on the right) rendered at 1, 4 and 16 spp with three filterings —
//! unfiltered (checker `filter` = 0, file `filterType` bilinear), trilinear (file trilinear,
//! checker filtered) and anisotropic (the defaults) — set through the materials' overrides,
//! timed, and compared with an unfiltered high-spp reference (cached under the bench output
//! folder): RMSE, relMSE and mean SSIM. It owns the suite, its reference cache and the
//! target check ("anisotropic at 1 spp beats unfiltered at 16 spp, at ≤ 1.5× the time of
//! unfiltered at 1 spp"); rendering and the plot are `speed_error`'s.

use super::report::{ErrorStats, Row};
use super::speed_error::{RELMSE_EPS, prepare, relmse, render};
use super::{BenchOptions, SuiteResult, ssim};
use shadenet_tracer::scene::Scene;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The frame B8 renders (unless `--size`): a quarter of `texture_plane.toml`'s 640×360.
pub const B8_SIZE: (u32, u32) = (320, 180);
/// The frame of `--quick`.
pub const B8_QUICK_SIZE: (u32, u32) = (96, 54);
/// Samples per pixel of the unfiltered reference (`--quick`: [`B8_QUICK_REFERENCE_SPP`]).
pub const B8_REFERENCE_SPP: u32 = 1024;
/// Samples per pixel of the `--quick` reference.
pub const B8_QUICK_REFERENCE_SPP: u32 = 128;
/// The sample counts measured.
pub const B8_SPPS: [u32; 3] = [1, 4, 16];
/// The time limit of the target check: anisotropic at 1 spp against unfiltered at 1 spp.
pub const TARGET_TIME_RATIO: f64 = 1.5;
/// Columns left out on each side of the seam between the two grounds in the per-half errors.
pub const SEAM: usize = 2;

/// The scene's checker material and its checker node.
const CHECKER: (&str, &str) = ("checker", "tile");
/// The scene's image material and its `file` node.
const IMAGE: (&str, &str) = ("image", "img");

/// How the textures are filtered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filtering {
    /// Checker `filter` = 0 (point-sampled), file `filterType` = bilinear (level 0).
    Unfiltered,
    /// File `filterType` = trilinear, the checker box-filtered.
    Trilinear,
    /// The defaults: file anisotropic, the checker box-filtered.
    Anisotropic,
}

impl Filtering {
    /// Every filtering, in the order measured.
    pub const ALL: [Filtering; 3] = [
        Filtering::Unfiltered,
        Filtering::Trilinear,
        Filtering::Anisotropic,
    ];

    /// Its name in rows and tables.
    pub fn name(self) -> &'static str {
        match self {
            Filtering::Unfiltered => "unfiltered",
            Filtering::Trilinear => "trilinear",
            Filtering::Anisotropic => "anisotropic",
        }
    }

    /// The `(material, node, input, value)` overrides that select it.
    pub fn overrides(self) -> Vec<(&'static str, &'static str, &'static str, serde_json::Value)> {
        match self {
            Filtering::Unfiltered => vec![
                (CHECKER.0, CHECKER.1, "filter", 0.into()),
                (IMAGE.0, IMAGE.1, "filterType", "bilinear".into()),
            ],
            Filtering::Trilinear => vec![(IMAGE.0, IMAGE.1, "filterType", "trilinear".into())],
            Filtering::Anisotropic => Vec::new(),
        }
    }

    /// Adds its overrides to the scene's materials; `Err` names a material the scene lacks.
    fn apply(self, s: &mut Scene) -> Result<(), String> {
        for (material, node, input, value) in self.overrides() {
            let m = s
                .materials
                .iter_mut()
                .find(|m| m.name == material)
                .ok_or_else(|| format!("the scene has no material `{material}`"))?;
            m.overrides.push((node.into(), input.into(), value));
        }
        Ok(())
    }
}

impl std::fmt::Display for Filtering {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One measured render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// The filtering.
    pub filtering: Filtering,
    /// Samples per pixel.
    pub spp: u32,
    /// Render time (median of the runs), seconds.
    pub time: f64,
    /// RMSE over the beauty's RGB against the reference.
    pub rmse: f64,
    /// relMSE ([`RELMSE_EPS`]).
    pub relmse: f64,
    /// Mean SSIM on luminance ([`ssim`]).
    pub ssim: f64,
    /// RMSE over the left half of the frame (the checker) and over the right half (the
    /// image texture).
    pub halves: (f64, f64),
}

/// RMSE over the RGB of the columns `cols` of `got` against `reference` (`width` pixels a
/// row).
pub fn rmse_columns(
    got: &[f32],
    reference: &[f32],
    width: usize,
    cols: std::ops::Range<usize>,
) -> f64 {
    let (mut sq, mut n) = (0.0f64, 0usize);
    for (i, (g, r)) in got
        .chunks_exact(3)
        .zip(reference.chunks_exact(3))
        .enumerate()
    {
        if cols.contains(&(i % width.max(1))) {
            for (a, b) in g.iter().zip(r) {
                let d = *a as f64 - *b as f64;
                sq += d * d;
                n += 1;
            }
        }
    }
    (sq / n.max(1) as f64).sqrt()
}

/// The scene compiled with `filtering`.
fn prepare_with(
    path: &Path,
    size: (u32, u32),
    filtering: Filtering,
) -> Result<shadenet_tracer::Renderer, String> {
    let mut bad = Ok(());
    let r = prepare(path, size, |s| bad = filtering.apply(s))?;
    bad.map(|()| r)
}

/// The suite.
pub fn b8(opts: &BenchOptions) -> SuiteResult {
    let size = opts
        .size
        .unwrap_or(if opts.quick { B8_QUICK_SIZE } else { B8_SIZE });
    let (ref_spp, reps): (u32, (usize, f64)) = if opts.quick {
        (B8_QUICK_REFERENCE_SPP, (1, 0.0))
    } else {
        (B8_REFERENCE_SPP, (5, 1.0))
    };
    let path = opts.scenes.join("texture_plane.toml");
    let threads = rayon::current_num_threads();
    let title = format!(
        "texture filtering on texture_plane.toml ({}×{}): error against an unfiltered {ref_spp}-spp reference vs render time (JIT, {threads} thr)",
        size.0, size.1
    );
    let fail = |why: String| SuiteResult {
        name: "B8",
        title: title.clone(),
        rows: Vec::new(),
        extra: format!("\nNote: B8 did not run: {why}\n"),
    };
    let mut unfiltered = match prepare_with(&path, size, Filtering::Unfiltered) {
        Ok(r) => r,
        Err(e) => return fail(format!("{}: {e}", path.display())),
    };
    let cache = opts.out.as_ref().map(|d| reference_path(d, size, ref_spp));
    let key = inputs_key(&path);
    let (reference, ref_note) = match cache.as_deref().and_then(|c| read_reference(c, key, size)) {
        Some(img) => (img, format!("read from {}", cache_name(&cache))),
        None => {
            let (t, img) = render(&mut unfiltered, ref_spp, (1, 0.0));
            let saved = match &cache {
                Some(c) => match write_reference(c, key, size, &img) {
                    Ok(()) => format!(", cached in {}", c.display()),
                    Err(e) => format!(", not cached ({}: {e})", c.display()),
                },
                None => String::new(),
            };
            (img, format!("rendered in {:.1} s{saved}", t.median))
        }
    };
    let ref64: Vec<f64> = reference.iter().map(|v| *v as f64).collect();
    let pixels = (size.0 * size.1) as u64;
    let (mut rows, mut points) = (Vec::new(), Vec::new());
    let mut first = Some(unfiltered);
    for filtering in Filtering::ALL {
        let prepared = match first.take() {
            Some(r) if filtering == Filtering::Unfiltered => Ok(r),
            _ => prepare_with(&path, size, filtering),
        };
        let mut r = match prepared {
            Ok(r) => r,
            Err(e) => return fail(format!("{} ({filtering}): {e}", path.display())),
        };
        for spp in B8_SPPS {
            let (timing, image) = render(&mut r, spp, reps);
            let error = ErrorStats::measure(&image, &ref64, 3);
            let s = ssim::mean_ssim_rgb(&image, &reference, size.0 as usize, size.1 as usize);
            points.push(Point {
                filtering,
                spp,
                time: timing.median,
                rmse: error.rmse,
                relmse: relmse(&image, &ref64),
                ssim: s.unwrap_or(f64::NAN),
                halves: {
                    // Each half without the SEAM columns next to the seam between the two
                    // materials: an edge between surfaces, which no texture filter smooths.
                    let (w, half) = (size.0 as usize, size.0 as usize / 2);
                    (
                        rmse_columns(&image, &reference, w, 0..half.saturating_sub(SEAM)),
                        rmse_columns(&image, &reference, w, (half + SEAM).min(w)..w),
                    )
                },
            });
            rows.push(Row {
                suite: "B8",
                case: format!("texture_plane {}×{} {spp} spp", size.0, size.1),
                backend: "jit".into(),
                config: format!("{filtering}, {threads} thr"),
                work: pixels * spp as u64,
                unit: "sample",
                time: timing,
                error: Some(error),
                ..Row::default()
            });
        }
    }
    let extra = format!(
        "\nReference: unfiltered at {ref_spp} spp ({ref_note}). RMSE and relMSE (ε = {RELMSE_EPS}) over the beauty's RGB; SSIM: mean SSIM on luminance (11×11 Gaussian window, σ 1.5, Wang et al. 2004; 1 = identical).\n\n{}\n{}\n",
        measured_markdown(&points),
        target_markdown(&points)
    );
    SuiteResult {
        name: "B8",
        title,
        rows,
        extra,
    }
}

/// Every measured point: filtering, spp, time, RMSE, relMSE, SSIM.
pub fn measured_markdown(points: &[Point]) -> String {
    let mut s = String::from(
        "| filtering | spp | time ms | RMSE | relMSE | SSIM | RMSE checker (left) | RMSE image (right) |\n|---|---|---|---|---|---|---|---|\n",
    );
    for p in points {
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} | {:.4e} | {:.4e} | {:.4} | {:.4e} | {:.4e} |",
            p.filtering,
            p.spp,
            p.time * 1e3,
            p.rmse,
            p.relmse,
            p.ssim,
            p.halves.0,
            p.halves.1
        );
    }
    s
}

/// The target of issue 16, measured: anisotropic at 1 spp against unfiltered at 16 spp
/// (RMSE) and against unfiltered at 1 spp (time).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    /// RMSE of anisotropic at 1 spp.
    pub aniso_rmse: f64,
    /// RMSE of unfiltered at 16 spp.
    pub unfiltered16_rmse: f64,
    /// Time of anisotropic at 1 spp over the time of unfiltered at 1 spp.
    pub time_ratio: f64,
}

impl Target {
    /// From the points; `None` when one of the three renders is missing.
    pub fn of(points: &[Point]) -> Option<Target> {
        let find =
            |f: Filtering, spp: u32| points.iter().find(|p| p.filtering == f && p.spp == spp);
        let a = find(Filtering::Anisotropic, 1)?;
        let u1 = find(Filtering::Unfiltered, 1)?;
        let u16 = find(Filtering::Unfiltered, 16)?;
        Some(Target {
            aniso_rmse: a.rmse,
            unfiltered16_rmse: u16.rmse,
            time_ratio: a.time / u1.time.max(1e-12),
        })
    }

    /// Lower error and no more than [`TARGET_TIME_RATIO`] the time.
    pub fn holds(&self) -> bool {
        self.aniso_rmse < self.unfiltered16_rmse && self.time_ratio <= TARGET_TIME_RATIO
    }
}

/// The target check as a sentence with both numbers.
pub fn target_markdown(points: &[Point]) -> String {
    let Some(t) = Target::of(points) else {
        return "Target check: not measured (a render is missing).\n".into();
    };
    format!(
        "Target check (issue 16): anisotropic at 1 spp has lower error than unfiltered at 16 spp, at no more than {TARGET_TIME_RATIO}× the time of unfiltered at 1 spp — RMSE {:.4e} vs {:.4e} ({}), time {:.2}× ({}): **{}**.\n",
        t.aniso_rmse,
        t.unfiltered16_rmse,
        if t.aniso_rmse < t.unfiltered16_rmse {
            "lower"
        } else {
            "not lower"
        },
        t.time_ratio,
        if t.time_ratio <= TARGET_TIME_RATIO {
            "within"
        } else {
            "over"
        },
        if t.holds() { "holds" } else { "does not hold" }
    )
}

/// The cached reference of a frame size and spp in the output folder `dir`.
pub fn reference_path(dir: &Path, size: (u32, u32), spp: u32) -> PathBuf {
    dir.join(format!("b8-reference-{}x{}-{spp}spp.bin", size.0, size.1))
}

fn cache_name(cache: &Option<PathBuf>) -> String {
    cache
        .as_ref()
        .map_or_else(String::new, |c| c.display().to_string())
}

/// The first bytes of a cached reference.
const MAGIC: &[u8; 8] = b"SNB8REF1";

/// FNV-1a over the scene file, the material networks beside it and the image texture: a
/// cached reference of other inputs is not reused (a changed renderer is not detected:
/// delete the file).
fn inputs_key(scene: &Path) -> u64 {
    let dir = scene.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for f in [
        scene.to_path_buf(),
        dir.join("materials/checker_unlit.json"),
        dir.join("materials/grid_texture.json"),
        dir.join("textures/grid.png"),
    ] {
        for b in std::fs::read(&f).unwrap_or_default() {
            h = (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

/// The reference at `path` when it is there and of these inputs and size (every value
/// finite); `None` otherwise, and it is rendered again.
fn read_reference(path: &Path, key: u64, size: (u32, u32)) -> Option<Vec<f32>> {
    let bytes = std::fs::read(path).ok()?;
    let n = size.0 as usize * size.1 as usize * 3;
    let header = MAGIC.len() + 16;
    if bytes.len() != header + 4 * n || &bytes[..8] != MAGIC {
        return None;
    }
    let u64_at = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().unwrap_or_default());
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap_or_default());
    if u64_at(8) != key || u32_at(16) != size.0 || u32_at(20) != size.1 {
        return None;
    }
    let img: Vec<f32> = bytes[header..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    img.iter().all(|v| v.is_finite()).then_some(img)
}

/// Writes the reference (temp file and rename).
fn write_reference(path: &Path, key: u64, size: (u32, u32), img: &[f32]) -> std::io::Result<()> {
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d)?;
    }
    let mut bytes = Vec::with_capacity(24 + 4 * img.len());
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&key.to_le_bytes());
    bytes.extend_from_slice(&size.0.to_le_bytes());
    bytes.extend_from_slice(&size.1.to_le_bytes());
    for v in img {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    super::write_file(path, bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(filtering: Filtering, spp: u32, time: f64, rmse: f64) -> Point {
        Point {
            filtering,
            spp,
            time,
            rmse,
            relmse: 0.0,
            ssim: 1.0,
            halves: (rmse, rmse),
        }
    }

    #[test]
    fn the_target_needs_lower_error_and_at_most_one_and_a_half_times_the_time() {
        let u1 = point(Filtering::Unfiltered, 1, 0.10, 0.2);
        let u16 = point(Filtering::Unfiltered, 16, 1.6, 0.05);
        let holds = [u1, u16, point(Filtering::Anisotropic, 1, 0.15, 0.04)];
        let t = Target::of(&holds).unwrap();
        assert!(t.holds() && (t.time_ratio - 1.5).abs() < 1e-12);
        assert!(target_markdown(&holds).contains("**holds**"));
        let slow = [u1, u16, point(Filtering::Anisotropic, 1, 0.16, 0.04)];
        assert!(!Target::of(&slow).unwrap().holds());
        assert!(target_markdown(&slow).contains("over"));
        let worse = [u1, u16, point(Filtering::Anisotropic, 1, 0.1, 0.05)];
        assert!(!Target::of(&worse).unwrap().holds());
        assert!(target_markdown(&worse).contains("**does not hold**"));
        assert!(Target::of(&[u1, u16]).is_none());
    }

    #[test]
    fn column_rmse_sees_only_its_columns() {
        // 2×1 pixels: the left one off by 0.3 in every channel, the right one exact.
        let got = [0.3f32, 0.3, 0.3, 1.0, 1.0, 1.0];
        let reference = [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0];
        assert!((rmse_columns(&got, &reference, 2, 0..1) - 0.3).abs() < 1e-7);
        assert_eq!(rmse_columns(&got, &reference, 2, 1..2), 0.0);
    }

    #[test]
    fn the_reference_cache_round_trips_and_rejects_other_inputs() {
        let dir = std::env::temp_dir().join(format!("shadenet-b8-cache-{}", std::process::id()));
        let p = reference_path(&dir, (2, 1), 64);
        assert!(p.ends_with("b8-reference-2x1-64spp.bin"));
        let img = [0.1f32, 0.2, 0.3, 0.4, 0.5, 0.6];
        write_reference(&p, 7, (2, 1), &img).unwrap();
        assert_eq!(read_reference(&p, 7, (2, 1)).unwrap(), img);
        assert!(read_reference(&p, 8, (2, 1)).is_none());
        assert!(read_reference(&p, 7, (1, 2)).is_none());
        assert!(read_reference(&p, 7, (3, 1)).is_none());
        std::fs::write(&p, b"SNB8REF1 truncated").unwrap();
        assert!(read_reference(&p, 7, (2, 1)).is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_variants_set_the_documented_inputs() {
        let names: Vec<_> = Filtering::ALL.iter().map(|f| f.name()).collect();
        assert_eq!(names, ["unfiltered", "trilinear", "anisotropic"]);
        let u = Filtering::Unfiltered.overrides();
        assert_eq!(u[0].1, "tile");
        assert_eq!(u[0].3, serde_json::json!(0));
        assert_eq!(u[1].3, serde_json::json!("bilinear"));
        assert_eq!(
            Filtering::Trilinear.overrides()[0].3,
            serde_json::json!("trilinear")
        );
        assert!(Filtering::Anisotropic.overrides().is_empty());
    }
}
