//! Light transport of closure materials (issue 15) in the renderer: next-event estimation
//! with MIS against BSDF sampling is unbiased (a MaterialX diffuse closure converges to the
//! Lambert material lit by light sampling alone), beats light sampling alone on a large
//! light, and BSDF rays past the depth limit still bring their MIS share of the light. The
//! light strategies (`render.light_strategy`): `light` and `bsdf` converge to the same image
//! as `mis`, `mis` written out is the default bit for bit, and on a small bright light over
//! a glossy and a diffuse surface MIS has the lowest error of the three at equal samples.
//! Needs the MaterialX libraries (fails under `CI` without them, skips otherwise).

mod common;

use shadenet::render::{RenderOptions, setup};
use shadenet::tracer::Film;
use std::path::{Path, PathBuf};

fn tmp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shadenet-pbr-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn have_libraries() -> bool {
    match shadenet::mtlx::locate(None) {
        Ok(_) => true,
        Err(e) if std::env::var_os("CI").is_some() => {
            panic!("CI needs the MaterialX libraries: {e}")
        }
        Err(e) => {
            eprintln!("skipped: {e}");
            false
        }
    }
}

const DIFFUSE: &str = r#"<?xml version="1.0"?>
<materialx version="1.39">
  <oren_nayar_diffuse_bsdf name="d" type="BSDF">
    <input name="color" type="color3" value="0.8, 0.8, 0.8" />
  </oren_nayar_diffuse_bsdf>
  <surface name="s" type="surfaceshader"><input name="bsdf" type="BSDF" nodename="d" /></surface>
  <surfacematerial name="M" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="s" />
  </surfacematerial>
</materialx>
"#;

/// A plane seen from above under a quad light of half-size `half` at height 1; `material`
/// is the `[materials.m]` body.
fn scene(material: &str, half: f64, spp: u32, diffuse_depth: u32) -> String {
    format!(
        r#"
[camera]
position = [0, 0.2, 3]
look_at = [0, 0, 0]
fov = 40
resolution = [8, 8]

[render]
spp = {spp}
max_diffuse_depth = {diffuse_depth}

[materials.m]
{material}

[meshes.plane]
type = "quad"

[[instances]]
mesh = "plane"
material = "m"
rotate = [-90, 0, 0]
scale = 4

[[lights]]
type = "quad"
corner = [{lo}, 1, {lo}]
edge_u = [{size}, 0, 0]
edge_v = [0, 0, {size}]
intensity = 1
samples = 1
"#,
        lo = -half,
        size = 2.0 * half
    )
}

fn render(dir: &Path, name: &str, text: &str) -> Film {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    let r = setup(Some(&path), &RenderOptions::default()).unwrap_or_else(|e| panic!("{e}\n{text}"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| r.render(&|_, _| {})).0
}

fn beauty(f: &Film) -> Vec<f64> {
    let l = f.layer("beauty").unwrap();
    (0..64).map(|i| l.at(i, 1) as f64).collect()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

fn rmse(a: &[f64], b: &[f64]) -> f64 {
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
}

const LAMBERT: &str = r#"inline = { nodes = [ { name = "surf", type = "lambert", inputs = { color = [0.8, 0.8, 0.8], diffuse = 1.0 } } ], outputs = { color = "surf.outColor" } }"#;

#[test]
fn mis_converges_to_light_sampling_and_beats_it_on_a_large_light() {
    if !have_libraries() {
        return;
    }
    let dir = tmp_dir("mis");
    std::fs::write(dir.join("diffuse.mtlx"), DIFFUSE).unwrap();
    let mx = r#"mtlx = "diffuse.mtlx""#;
    let reference = beauty(&render(&dir, "ref", &scene(LAMBERT, 3.0, 1024, 0)));
    let lambert = beauty(&render(&dir, "lam", &scene(LAMBERT, 3.0, 16, 0)));
    let closure = beauty(&render(&dir, "mx", &scene(mx, 3.0, 16, 0)));
    let converged = beauty(&render(&dir, "mx256", &scene(mx, 3.0, 256, 0)));
    let (m_ref, m_mx) = (mean(&reference), mean(&converged));
    eprintln!(
        "mean: reference {m_ref}, closure {m_mx}; RMSE at 16 spp: light sampling {}, MIS {}",
        rmse(&lambert, &reference),
        rmse(&closure, &reference)
    );
    // Unbiased: counting a light twice (no MIS weight on BSDF rays) would add ~40 %, never
    // counting BSDF rays would lose ~20 %.
    assert!((m_mx - m_ref).abs() < 0.02 * m_ref, "{m_mx} vs {m_ref}");
    assert!(
        rmse(&closure, &reference) < 0.75 * rmse(&lambert, &reference),
        "MIS must beat light sampling alone on a large light"
    );
}

#[test]
fn bsdf_rays_past_the_depth_limit_still_bring_their_share_of_the_light() {
    if !have_libraries() {
        return;
    }
    let dir = tmp_dir("depth");
    std::fs::write(dir.join("diffuse.mtlx"), DIFFUSE).unwrap();
    let mx = r#"mtlx = "diffuse.mtlx""#;
    // Nothing but the plane and the light: a BSDF ray either reaches the light or escapes,
    // so shading it (depth 2) or only gathering the light (depth 0) give the same image.
    let shallow = beauty(&render(&dir, "d0", &scene(mx, 0.5, 4, 0)));
    let deep = beauty(&render(&dir, "d2", &scene(mx, 0.5, 4, 2)));
    assert_eq!(shallow, deep);
    assert!(mean(&shallow) > 0.0);
}

const GLOSSY: &str = r#"<?xml version="1.0"?>
<materialx version="1.39">
  <conductor_bsdf name="c" type="BSDF">
    <input name="ior" type="color3" value="0.2, 0.4, 1.4" />
    <input name="extinction" type="color3" value="3.9, 2.4, 1.9" />
    <input name="roughness" type="vector2" value="ROUGH, ROUGH" />
  </conductor_bsdf>
  <surface name="s" type="surfaceshader"><input name="bsdf" type="BSDF" nodename="c" /></surface>
  <surfacematerial name="M" type="material">
    <input name="surfaceshader" type="surfaceshader" nodename="s" />
  </surfacematerial>
</materialx>
"#;

/// A glossy conductor (roughness `rough`, left) and a diffuse closure (right) side by side,
/// seen from above at an angle, under a quad light of half-size `half` and `intensity` at
/// height 1.5; `strategy` is the `render.light_strategy` line (or nothing).
fn two_surfaces(
    dir: &Path,
    rough: f64,
    half: f64,
    intensity: f64,
    spp: u32,
    strategy: &str,
) -> String {
    std::fs::write(dir.join("diffuse.mtlx"), DIFFUSE).unwrap();
    std::fs::write(
        dir.join(format!("glossy{rough}.mtlx")),
        GLOSSY.replace("ROUGH", &rough.to_string()),
    )
    .unwrap();
    format!(
        r#"
[camera]
position = [0, 3, 2]
look_at = [0, 0, 0]
fov = 60
resolution = [8, 8]

[render]
spp = {spp}
max_diffuse_depth = 1
{strategy}

[materials.glossy]
mtlx = "glossy{rough}.mtlx"

[materials.diffuse]
mtlx = "diffuse.mtlx"

[meshes.plane]
type = "quad"

[[instances]]
mesh = "plane"
material = "glossy"
rotate = [-90, 0, 0]
translate = [-1, 0, 0]

[[instances]]
mesh = "plane"
material = "diffuse"
rotate = [-90, 0, 0]
translate = [1, 0, 0]

[[lights]]
type = "quad"
corner = [{x}, 1.5, {lo}]
edge_u = [{size}, 0, 0]
edge_v = [0, 0, {size}]
intensity = {intensity}
samples = 1
"#,
        lo = -half,
        x = -0.6 - half,
        size = 2.0 * half
    )
}

const STRATEGIES: [&str; 3] = ["mis", "light", "bsdf"];

fn strategy_line(s: &str) -> String {
    format!("light_strategy = \"{s}\"")
}

#[test]
fn every_light_strategy_converges_to_the_same_image() {
    if !have_libraries() {
        return;
    }
    let dir = tmp_dir("strategies");
    let (rough, half, intensity) = (0.3, 0.6, 6.0);
    let scene = |spp, s: &str| two_surfaces(&dir, rough, half, intensity, spp, s);
    let reference = beauty(&render(&dir, "ref", &scene(4096, &strategy_line("mis"))));
    // `mis` written out is the default, bit for bit.
    let default = beauty(&render(&dir, "default", &scene(16, "")));
    let mis = beauty(&render(&dir, "mis", &scene(16, &strategy_line("mis"))));
    assert_eq!(default, mis);
    let m_ref = mean(&reference);
    assert!(m_ref > 0.05, "the scene is lit: {m_ref}");
    // Relative tolerances of the 1024-spp means: measured, light sampling is within 0.2 %
    // of the reference and BSDF sampling (far noisier on the diffuse half) within 4.1 %, 1.6
    // standard errors. Broken, they move by more: BSDF rays that still took the MIS weight
    // with `light` (the light counted twice) +4.7 %, with `bsdf` (its share lost) −95 %; a
    // `bsdf` light loop that kept the area light +100 %.
    for (s, tol) in STRATEGIES.into_iter().zip([0.02, 0.02, 0.08]) {
        let img = beauty(&render(&dir, s, &scene(1024, &strategy_line(s))));
        // The standard error of the image mean from the pixels' errors (for the message).
        let se = rmse(&img, &reference) / (img.len() as f64).sqrt();
        let m = mean(&img);
        eprintln!("{s}: mean {m} (reference {m_ref}), standard error {se}");
        assert!(
            (m - m_ref).abs() < tol * m_ref,
            "{s}: mean {m} vs {m_ref} (standard error {se})"
        );
    }
}

#[test]
fn mis_has_the_lowest_error_at_equal_samples_on_a_small_bright_light() {
    if !have_libraries() {
        return;
    }
    let dir = tmp_dir("small-light");
    // Light sampling is poor on the sharp highlight, BSDF sampling on the diffuse surface.
    let (rough, half, intensity) = (0.03, 0.3, 10.0);
    let scene = |spp, s: &str| two_surfaces(&dir, rough, half, intensity, spp, &strategy_line(s));
    let reference = beauty(&render(&dir, "ref", &scene(2048, "mis")));
    let err: Vec<f64> = STRATEGIES
        .iter()
        .map(|s| rmse(&beauty(&render(&dir, s, &scene(16, s))), &reference))
        .collect();
    eprintln!(
        "RMSE at 16 spp: mis {}, light {}, bsdf {}",
        err[0], err[1], err[2]
    );
    assert!(
        err[0] < 0.9 * err[1] && err[0] < 0.9 * err[2],
        "MIS must beat light sampling alone and BSDF sampling alone: {err:?}"
    );
}
