//! Image environment lights (issue 15, item 5): the lat-long convention, the importance
//! sampling distribution (pdf integrates to 1, chi-square of sampled directions, the light
//! loop's pdf equals `light_pdf`), unbiased irradiance against quadrature and its error
//! against uniform sampling, renders under a map (a white Lambertian quad against the
//! quadrature irradiance, a constant map against the constant environment), black maps, bad
//! input, and the committed `pbr_sky.hdr` equal to its generator's output.

mod common;
use common::stats::chi_square;

use shadenet::generate::{Sky, sky, sky_hdr};
use shadenet::graph::nodes::env_image::EnvImage;
use shadenet::graph::nodes::{LightDesc, LightKind};
use shadenet::render::{RenderOptions, setup};
use shadenet::runtime::envmap::EnvMap;
use shadenet::runtime::lights::{self, Light};
use shadenet::tracer::envmap::{load, read_hdr, write_hdr};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn tmp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shadenet-envmap-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A map of `w × h` texels from `f(column, row)`, rotated by `deg` degrees.
fn image(w: u32, h: u32, deg: f64, f: impl Fn(u32, u32) -> [f32; 3]) -> Arc<EnvImage> {
    let texels = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| f(i, j))
        .collect();
    Arc::new(EnvImage {
        source: "test".into(),
        width: w,
        height: h,
        texels,
        rotation: deg.to_radians(),
    })
}

/// The generated sky (a small bright sun, gradient, ground) at `w × h`.
fn sky_image(w: u32, h: u32, deg: f64) -> Arc<EnvImage> {
    let texels = sky(&Sky {
        width: w,
        height: h,
        ..Sky::default()
    })
    .unwrap();
    image(w, h, deg, |i, j| texels[(j * w + i) as usize])
}

/// A smooth map with a bright spot (for the chi-square: far from uniform, every texel lit).
fn spotty_image(w: u32, h: u32) -> Arc<EnvImage> {
    image(w, h, 0.0, |i, j| {
        let (di, dj) = (i as f32 - 0.7 * w as f32, j as f32 - 0.3 * h as f32);
        let spot = 40.0 * (-(di * di + dj * dj) / 6.0).exp();
        [0.1 + spot, 0.05 + 0.02 * j as f32 + spot, 0.3 + spot]
    })
}

/// The direction of map angles (θ from +y, φ from −z towards +x), then turned by `deg`
/// about +y — the documented convention, written independently of the library's code.
fn direction(theta: f64, phi: f64, deg: f64) -> [f64; 3] {
    let (xm, ym, zm) = (
        theta.sin() * phi.sin(),
        theta.cos(),
        -theta.sin() * phi.cos(),
    );
    let (c, s) = (deg.to_radians().cos(), deg.to_radians().sin());
    [xm * c + zm * s, ym, -xm * s + zm * c]
}

/// splitmix64 uniforms in [0, 1).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn luminance(t: [f32; 3]) -> f64 {
    0.2126 * t[0] as f64 + 0.7152 * t[1] as f64 + 0.0722 * t[2] as f64
}

#[test]
fn the_lat_long_convention_is_the_documented_one() {
    // One bright texel: column 5 of 8 (u in [0.625, 0.75]), row 1 of 4 (v in [0.25, 0.5]).
    let bright = |i, j| if (i, j) == (5, 1) { [8.0; 3] } else { [0.0; 3] };
    let (theta, phi) = (0.375 * PI, 2.0 * PI * (0.6875 - 0.5));
    for deg in [0.0, 90.0, -37.0] {
        let map = EnvMap::new(image(8, 4, deg, bright));
        let at = map.radiance(direction(theta, phi, deg));
        assert!(
            (at[0] - 8.0).abs() < 1e-6,
            "rotation {deg}: {at:?} at the texel's centre"
        );
        let opposite = map.radiance(direction(PI - theta, phi + PI, deg));
        assert_eq!(opposite, [0.0; 3], "rotation {deg}");
    }
    // The centre column faces −z; at 90° it faces −x (counter-clockwise seen from above).
    let centre = |i, _| if i == 3 || i == 4 { [1.0; 3] } else { [0.0; 3] };
    let m0 = EnvMap::new(image(8, 4, 0.0, centre));
    assert!((m0.radiance([0.0, 0.0, -1.0])[0] - 1.0).abs() < 1e-12);
    assert_eq!(m0.radiance([0.0, 0.0, 1.0]), [0.0; 3]);
    let m90 = EnvMap::new(image(8, 4, 90.0, centre));
    assert!((m90.radiance([-1.0, 0.0, 0.0])[0] - 1.0).abs() < 1e-12);
    assert_eq!(m90.radiance([0.0, 0.0, -1.0]), [0.0; 3]);
    // The top row is up.
    let top = |_, j| if j == 0 { [1.0; 3] } else { [0.0; 3] };
    let mt = EnvMap::new(image(8, 4, 0.0, top));
    assert_eq!(mt.radiance([0.0, 1.0, 0.0]), [1.0; 3]);
    assert_eq!(mt.radiance([0.0, -1.0, 0.0]), [0.0; 3]);
}

/// ∫ pdf dω over the sphere by the midpoint rule on (θ, φ): 1 to rounding where the grid
/// lines up with the texels, to 10⁻³ for a rotated map whose sun cuts across grid cells.
#[test]
fn the_pdf_integrates_to_one_over_the_sphere() {
    for (deg, tol) in [(0.0, 1e-9), (37.0, 1e-3)] {
        let (w, h) = (64u32, 32u32);
        let map = EnvMap::new(sky_image(w, h, deg));
        let (nt, np) = (h as usize * 16, w as usize * 16);
        let (dt, dp) = (PI / nt as f64, 2.0 * PI / np as f64);
        let mut sum = 0.0;
        for a in 0..nt {
            let theta = (a as f64 + 0.5) * dt;
            for b in 0..np {
                let phi = -PI + (b as f64 + 0.5) * dp;
                sum += map.pdf(direction(theta, phi, deg)) * theta.sin() * dt * dp;
            }
        }
        eprintln!("rotation {deg}°: ∫ pdf dω = {sum}");
        assert!((sum - 1.0).abs() < tol, "rotation {deg}: ∫ pdf = {sum}");
    }
}

/// 2·10⁵ sampled directions binned on (cos θ, φ): their counts against the probabilities
/// the documented distribution gives each bin (filtered texel luminance × sin θ at the row
/// centre, integrated exactly over the bin's overlap with the texel rows), p ≥ 10⁻⁴.
#[test]
fn sampled_directions_follow_the_pdf() {
    let (w, h) = (32u32, 16u32);
    let img = spotty_image(w, h);
    let map = EnvMap::new(img.clone());
    let (bz, bp) = (20usize, 16usize);
    let n = 200_000;
    let mut observed = vec![0.0; bz * bp];
    let mut rng = Rng(7);
    for _ in 0..n {
        let (d, pdf) = map.sample([rng.next(), rng.next()]).unwrap();
        assert!(pdf > 0.0);
        let z = d[1].clamp(-1.0, 1.0);
        let phi = d[0].atan2(-d[2]) + PI; // [0, 2π], from the map's left edge
        let iz = (((1.0 - z) / 2.0 * bz as f64) as usize).min(bz - 1);
        let ip = ((phi / (2.0 * PI) * bp as f64) as usize).min(bp - 1);
        observed[iz * bp + ip] += 1.0;
    }
    // Texel probabilities (the documented function: luminance filtered by (1/8, 3/4, 1/8)
    // across, wrapping, and down, clamped, times sin θ), then per bin: φ bins hold whole
    // columns (bp divides w); the θ overlap of the bin's cos θ band with each row is exact.
    let lum = |i: i64, j: i64| {
        let (i, j) = (i.rem_euclid(w as i64), j.clamp(0, h as i64 - 1));
        luminance(img.texels[(j * w as i64 + i) as usize])
    };
    let k = [0.125, 0.75, 0.125];
    let f = |i: u32, j: u32| {
        let mut s = 0.0;
        for (a, ka) in k.iter().enumerate() {
            for (b, kb) in k.iter().enumerate() {
                s += ka * kb * lum(i as i64 + a as i64 - 1, j as i64 + b as i64 - 1);
            }
        }
        s * (PI * (j as f64 + 0.5) / h as f64).sin()
    };
    let total: f64 = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| f(i, j))
        .sum();
    let mut expected = vec![0.0; bz * bp];
    for iz in 0..bz {
        // cos θ from 1 − 2 iz / bz down: θ from acos(top) to acos(bottom).
        let t0 = (1.0 - 2.0 * iz as f64 / bz as f64).clamp(-1.0, 1.0).acos();
        let t1 = (1.0 - 2.0 * (iz + 1) as f64 / bz as f64)
            .clamp(-1.0, 1.0)
            .acos();
        for j in 0..h {
            let (r0, r1) = (PI * j as f64 / h as f64, PI * (j + 1) as f64 / h as f64);
            let overlap = (t1.min(r1) - t0.max(r0)).max(0.0) / (r1 - r0);
            for i in 0..w {
                let ip = (i as usize * bp) / w as usize;
                expected[iz * bp + ip] += n as f64 * overlap * f(i, j) / total;
            }
        }
    }
    let (chi, dof, p) = chi_square(&observed, &expected).unwrap();
    eprintln!("chi-square {chi:.1} over {dof} degrees of freedom: p = {p:.4}");
    assert!(p >= 1e-4, "chi-square {chi} ({dof} dof): p = {p}");
}

fn map_light(map: Arc<EnvImage>, samples: u32, power: [f64; 3]) -> Light {
    let desc = LightDesc::new(
        "sky",
        LightKind::Environment {
            samples,
            map: Some(map),
        },
        power,
    )
    .unwrap();
    Light::from_desc(&desc)
}

/// The light loop's sample and `light_pdf` of its direction agree to the bit (f64); the f32
/// sample is the f64 one rounded; `cl` is power × radiance / pdf.
#[test]
fn light_pdf_of_a_sample_is_its_pdf() {
    let light = map_light(sky_image(64, 32, 30.0), 4, [0.5, 1.0, 2.0]);
    let env = light.env_map().unwrap();
    let p = [0.3, -1.0, 2.0];
    for seed in 0..2000u32 {
        for k in 0..4 {
            let s = lights::sample::<f64>(&light, 2, k, p, seed).unwrap();
            let q = lights::light_pdf(&light, p, s.l, s.to);
            assert_eq!(s.pdf, q, "seed {seed}, sample {k}");
            assert!(s.pdf > 0.0);
            let rad = env.radiance(s.l);
            for c in 0..3 {
                let want = [0.5, 1.0, 2.0][c] * rad[c] / s.pdf;
                assert!((s.cl[c] - want).abs() <= 1e-12 * want.abs().max(1e-300));
            }
            let s32 = lights::sample::<f32>(&light, 2, k, p.map(|x| x as f32), seed).unwrap();
            assert_eq!(s32.l, s.l.map(|x| x as f32));
            assert_eq!(s32.cl, s.cl.map(|x| x as f32));
            assert_eq!(s32.pdf, s.pdf as f32);
        }
    }
}

/// Irradiance ∫ L(ω) max(0, n·ω) dω by the midpoint rule on a fine (θ, φ) grid.
fn irradiance_quadrature(light: &Light, n: [f64; 3]) -> [f64; 3] {
    let (nt, np) = (1024usize, 2048usize);
    let (dt, dp) = (PI / nt as f64, 2.0 * PI / np as f64);
    let mut e = [0.0; 3];
    for a in 0..nt {
        let theta = (a as f64 + 0.5) * dt;
        for b in 0..np {
            let d = direction(theta, -PI + (b as f64 + 0.5) * dp, 0.0);
            let cos = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
            if cos > 0.0 {
                let l = lights::environment_radiance(light, d).unwrap();
                for c in 0..3 {
                    e[c] += l[c] * cos * theta.sin() * dt * dp;
                }
            }
        }
    }
    e
}

/// The light loop's irradiance estimate at normal `n` with `m` samples of seed `seed`.
fn irradiance_light_loop(light: &Light, n: [f64; 3], seed: u32, m: u32) -> f64 {
    (0..m)
        .map(|k| {
            let s = lights::sample::<f64>(light, 0, k, [0.0; 3], seed).unwrap();
            let cos = (n[0] * s.l[0] + n[1] * s.l[1] + n[2] * s.l[2]).max(0.0);
            luminance(s.cl.map(|x| x as f32)) * cos * m as f64
        })
        .sum::<f64>()
        / m as f64
}

/// The same estimate with `m` uniformly distributed directions.
fn irradiance_uniform(light: &Light, n: [f64; 3], rng: &mut Rng, m: u32) -> f64 {
    (0..m)
        .map(|_| {
            let z = 1.0 - 2.0 * rng.next();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * PI * rng.next();
            let d = [r * phi.cos(), z, r * phi.sin()];
            let cos = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]).max(0.0);
            let l = lights::environment_radiance(light, d).unwrap();
            luminance(l.map(|x| x as f32)) * cos * 4.0 * PI
        })
        .sum::<f64>()
        / m as f64
}

/// Importance sampling is unbiased (its mean over 400 points per normal is the quadrature's
/// irradiance within 4σ) and, with the sun in the map, far less noisy than uniform sampling
/// at the same sample count where the surface faces the sun: the RMSE of one 16-sample
/// estimate, relative to the irradiance, is measured for both and importance sampling must
/// be at least 3× better.
#[test]
fn importance_sampling_is_unbiased_and_beats_uniform_sampling() {
    let m = 16;
    let light = map_light(sky_image(128, 64, 0.0), m, [1.0; 3]);
    let normals = [
        [0.0, 1.0, 0.0],
        [0.6, 0.8, 0.0],
        [0.0, 0.0, -1.0],
        [-0.8, 0.0, 0.6],
    ];
    let mut rng = Rng(11);
    for n in normals {
        let reference = luminance(irradiance_quadrature(&light, n).map(|x| x as f32));
        let trials = 400;
        let (mut is_se, mut un_se, mut is_sum, mut is_sq) = (0.0, 0.0, 0.0, 0.0);
        for t in 0..trials {
            let a = irradiance_light_loop(&light, n, 1000 + t, m);
            let b = irradiance_uniform(&light, n, &mut rng, m);
            is_se += (a - reference) * (a - reference);
            un_se += (b - reference) * (b - reference);
            is_sum += a;
            is_sq += a * a;
        }
        let t = trials as f64;
        let mean = is_sum / t;
        let sigma = ((is_sq / t - mean * mean).max(0.0) / t).sqrt();
        let (is_rmse, un_rmse) = ((is_se / t).sqrt(), (un_se / t).sqrt());
        eprintln!(
            "normal {n:?}: E = {reference:.4}; importance mean {mean:.4} ± {sigma:.4}; \
             RMSE of a {m}-sample estimate: importance {:.4} ({:.1} %), uniform {:.4} ({:.1} %)",
            is_rmse,
            100.0 * is_rmse / reference,
            un_rmse,
            100.0 * un_rmse / reference
        );
        assert!(
            (mean - reference).abs() <= 4.0 * sigma + 1e-3 * reference,
            "normal {n:?}: importance mean {mean} vs quadrature {reference} (σ {sigma})"
        );
        // Facing the sun, importance sampling finds it; facing away (the last normal) it
        // spends samples on the sun behind the surface and only has to stay unbiased.
        if n[1] * 0.574 - n[2] * 0.819 > 0.0 {
            assert!(
                is_rmse * 3.0 < un_rmse,
                "normal {n:?}: {is_rmse} vs {un_rmse}"
            );
        }
    }
}

/// A scene of a white Lambertian quad facing +z, seen from above, under `light` (a TOML
/// `[[lights]]` table's keys).
fn quad_scene(light: &str, fov: f64) -> String {
    format!(
        r#"
[camera]
position = [0, 0, 2]
look_at = [0, 0, 0]
fov = {fov}
resolution = [4, 4]

[render]
spp = 16

[materials.plane.inline]
nodes = [ {{ name = "surf", type = "lambert", inputs = {{ color = [1, 1, 1], diffuse = 1.0 }} }} ]
outputs = {{ color = "surf.outColor" }}

[meshes.plane]
type = "quad"

[[instances]]
mesh = "plane"
material = "plane"
scale = 2

[[lights]]
type = "environment"
{light}
"#
    )
}

/// Renders a scene text on 2 threads: the beauty pixels (RGBA).
fn render_beauty(dir: &Path, text: &str) -> Vec<[f32; 4]> {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let r = setup(Some(&path), &RenderOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let film = pool.install(|| r.render(&|_, _| {})).0;
    let beauty = film.layer("beauty").unwrap();
    (0..16)
        .map(|i| std::array::from_fn(|c| beauty.at(i, c)))
        .collect()
}

/// Mean and standard error of channel `c` over the pixels.
fn mean_sigma(px: &[[f32; 4]], c: usize) -> (f64, f64) {
    let n = px.len() as f64;
    let mean = px.iter().map(|p| p[c] as f64).sum::<f64>() / n;
    let var = px.iter().map(|p| (p[c] as f64 - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

/// A white Lambertian quad under the generated sky (rotated 90°, read back from a `.hdr`)
/// reflects E/π, E the quadrature irradiance of the same map: within 4σ of the pixels'
/// spread (each pixel 16 spp × 16 light samples).
#[test]
fn a_white_surface_under_a_map_reflects_the_quadrature_irradiance() {
    let dir = tmp_dir("lambert");
    let p = Sky {
        width: 128,
        height: 64,
        ..Sky::default()
    };
    std::fs::write(dir.join("sky.hdr"), sky_hdr(&p).unwrap()).unwrap();
    let (w, h, texels) = load(&dir.join("sky.hdr")).unwrap();
    let light = map_light(
        image(w, h, 90.0, |i, j| texels[(j * w + i) as usize]),
        16,
        [1.0; 3],
    );
    let e = irradiance_quadrature(&light, [0.0, 0.0, 1.0]);
    let px = render_beauty(
        &dir,
        &quad_scene("map = \"sky.hdr\"\nrotation = 90\nsamples = 16", 20.0),
    );
    for (c, e) in e.iter().enumerate() {
        let (mean, sigma) = mean_sigma(&px, c);
        let want = e / PI;
        eprintln!("channel {c}: {mean:.5} ± {sigma:.5}, quadrature {want:.5}");
        assert!(
            (mean - want).abs() <= 4.0 * sigma + 1e-3 * want,
            "channel {c}: {mean} ± {sigma} vs {want}"
        );
    }
}

/// A map whose texels all equal c lights the white quad as the constant environment of
/// color c does (both c, within 4σ), and rays that miss see exactly c under both.
#[test]
fn a_constant_map_is_the_constant_environment() {
    let dir = tmp_dir("constant");
    let c = [0.5f32, 0.75, 1.0];
    std::fs::write(dir.join("flat.hdr"), write_hdr(16, 8, &[c; 128])).unwrap();
    let (_, _, back) = load(&dir.join("flat.hdr")).unwrap();
    assert!(
        back.iter().all(|t| *t == c),
        "0.5, 0.75 and 1 are exact in RGBE"
    );
    let map = render_beauty(&dir, &quad_scene("map = \"flat.hdr\"\nsamples = 16", 20.0));
    let constant = render_beauty(
        &dir,
        &quad_scene("color = [0.5, 0.75, 1.0]\nsamples = 16", 20.0),
    );
    for (ch, want) in c.iter().enumerate() {
        let (a, sa) = mean_sigma(&map, ch);
        let (b, sb) = mean_sigma(&constant, ch);
        let want = *want as f64;
        eprintln!("channel {ch}: map {a:.5} ± {sa:.5}, constant {b:.5} ± {sb:.5}, exact {want}");
        assert!(
            (a - want).abs() <= 4.0 * sa + 1e-5,
            "map: {a} ± {sa} vs {want}"
        );
        assert!(
            (b - want).abs() <= 4.0 * sb + 1e-5,
            "constant: {b} ± {sb} vs {want}"
        );
    }
    // A wide view: the corners miss the quad and see the environment alone.
    let map = render_beauty(&dir, &quad_scene("map = \"flat.hdr\"", 150.0));
    let constant = render_beauty(&dir, &quad_scene("color = [0.5, 0.75, 1.0]", 150.0));
    for i in [0, 3, 12, 15] {
        assert_eq!(map[i][3], 0.0, "pixel {i} misses the quad");
        assert_eq!(map[i], constant[i], "pixel {i}");
        for ch in 0..3 {
            assert!(
                (map[i][ch] - c[ch]).abs() <= 1e-6 * c[ch],
                "pixel {i}: {:?}",
                map[i]
            );
        }
    }
}

/// A black map gives no light and no samples (nothing divides by zero); its scene renders
/// black.
#[test]
fn a_black_map_gives_no_light() {
    let light = map_light(image(8, 4, 0.0, |_, _| [0.0; 3]), 4, [1.0; 3]);
    assert_eq!(lights::sample_count(&light), 0);
    assert!(light.env_map().unwrap().is_black());
    assert_eq!(
        lights::light_pdf(&light, [0.0; 3], [0.0, 1.0, 0.0], [0.0; 3]),
        0.0
    );
    assert_eq!(light.env_map().unwrap().sample([0.5, 0.5]), None);
    let dir = tmp_dir("black");
    std::fs::write(dir.join("black.hdr"), write_hdr(8, 4, &[[0.0; 3]; 32])).unwrap();
    let px = render_beauty(&dir, &quad_scene("map = \"black.hdr\"", 150.0));
    assert!(px.iter().all(|p| p[..3] == [0.0; 3]), "{px:?}");
}

/// The `.hdr` writer and reader round-trip (RGBE-rounded: 8 mantissa bits), with and
/// without run-length encoding.
#[test]
fn hdr_files_round_trip() {
    for w in [5u32, 64] {
        let texels: Vec<[f32; 3]> = (0..w * 3)
            .map(|i| {
                [
                    i as f32 * 0.37,
                    1e-3 * i as f32,
                    if i % 7 == 0 { 50.0 } else { 0.0 },
                ]
            })
            .collect();
        let (rw, rh, back) = read_hdr(&write_hdr(w, 3, &texels)).unwrap();
        assert_eq!((rw, rh), (w, 3));
        for (a, b) in texels.iter().zip(&back) {
            let m = a[0].max(a[1]).max(a[2]);
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= m / 128.0, "{a:?} → {b:?}");
            }
        }
    }
}

/// Loads a scene whose environment light is `light`, expecting an error containing every
/// one of `want`.
fn scene_error(dir: &Path, light: &str, want: &[&str]) {
    let path = dir.join("scene.toml");
    std::fs::write(&path, quad_scene(light, 20.0)).unwrap();
    let e = shadenet::tracer::scene::load(&path).expect_err(light);
    let text = shadenet::graph::error_chain(&e);
    for w in want {
        assert!(text.contains(w), "{light}: `{text}` lacks `{w}`");
    }
    assert!(text.contains("scene.toml"), "{text}");
}

#[test]
fn bad_maps_fail_clearly() {
    let dir = tmp_dir("bad");
    let key = "`lights[0].map`";
    scene_error(
        &dir,
        "map = \"none.hdr\"",
        &[key, "none.hdr", "No such file"],
    );
    scene_error(
        &dir,
        "map = \"sky.png\"",
        &[key, ".hdr (Radiance RGBE) or .exr"],
    );
    std::fs::write(dir.join("junk.hdr"), b"GIF89a junk").unwrap();
    scene_error(
        &dir,
        "map = \"junk.hdr\"",
        &[key, "junk.hdr", "not a Radiance .hdr file"],
    );
    let head = |res: &str| format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{res}\n").into_bytes();
    std::fs::write(dir.join("empty.hdr"), head("-Y 0 +X 16")).unwrap();
    scene_error(&dir, "map = \"empty.hdr\"", &[key, "the image is empty"]);
    // Absurd sizes are refused from the header, before anything is allocated.
    std::fs::write(dir.join("huge.hdr"), head("-Y 100000 +X 200000")).unwrap();
    scene_error(&dir, "map = \"huge.hdr\"", &[key, "too large"]);
    std::fs::write(dir.join("wide.hdr"), head("-Y 8192 +X 16384")).unwrap();
    scene_error(&dir, "map = \"wide.hdr\"", &[key, "too large"]);
    let mut short = write_hdr(16, 8, &[[1.0; 3]; 128]);
    short.truncate(short.len() - 20);
    std::fs::write(dir.join("short.hdr"), short).unwrap();
    scene_error(
        &dir,
        "map = \"short.hdr\"",
        &[key, "short.hdr: scanline", "ends early"],
    );
    std::fs::write(
        dir.join("xyz.hdr"),
        b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n",
    )
    .unwrap();
    scene_error(
        &dir,
        "map = \"xyz.hdr\"",
        &[key, "unsupported pixel format"],
    );
    std::fs::write(dir.join("flip.hdr"), head("+Y 4 +X 8")).unwrap();
    scene_error(
        &dir,
        "map = \"flip.hdr\"",
        &[key, "only `-Y height +X width`"],
    );
    // NaN, infinite and negative texels (EXR can hold them), named by file and texel.
    for (name, bad) in [("nan", f32::NAN), ("inf", f32::INFINITY), ("neg", -1.0)] {
        let file = dir.join(format!("{name}.exr"));
        exr::prelude::write_rgb_file(&file, 4, 2, |x, y| {
            if (x, y) == (3, 1) {
                (0.5, bad, 0.5)
            } else {
                (0.5f32, 0.5f32, 0.5f32)
            }
        })
        .unwrap();
        scene_error(
            &dir,
            &format!("map = \"{name}.exr\""),
            &[
                key,
                &format!("{name}.exr"),
                "texel (3, 1) has green",
                "finite and ≥ 0",
            ],
        );
    }
    // A good EXR loads, rows from the top.
    exr::prelude::write_rgb_file(dir.join("ok.exr"), 4, 2, |x, y| {
        (x as f32, y as f32, 1.0f32)
    })
    .unwrap();
    let (w, h, t) = load(&dir.join("ok.exr")).unwrap();
    assert_eq!((w, h), (4, 2));
    assert_eq!(t[4 + 3], [3.0, 1.0, 1.0]);
    scene_error(
        &dir,
        "rotation = 10",
        &["`lights[0].rotation`", "give `map` as well"],
    );
    scene_error(
        &dir,
        "map = \"ok.exr\"\nrotation = nan",
        &["`lights[0].rotation`"],
    );
}

/// The committed map of `examples/scenes/pbr.toml` is the generator's output, byte for byte
/// (`shadenet gen sky -o examples/scenes/pbr_sky.hdr` with the defaults remakes it).
#[test]
fn the_committed_sky_is_the_generators_output() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/pbr_sky.hdr");
    let committed = std::fs::read(&path).unwrap();
    let generated = sky_hdr(&Sky::default()).unwrap();
    assert!(committed.len() < 150 * 1024, "{} bytes", committed.len());
    assert!(
        committed == generated,
        "{} differs from `shadenet gen sky`",
        path.display()
    );
    // The sun is small and bright: most of the light from a few texels.
    let (w, h, t) = read_hdr(&committed).unwrap();
    assert_eq!((w, h), (256, 128));
    let map = EnvMap::new(image(w, h, 0.0, |i, j| t[(j * w + i) as usize]));
    let sun = map.pdf(direction(PI / 2.0 - 35f64.to_radians(), 0.0, 0.0));
    let zenith_ish = map.pdf(direction(0.3, 1.0, 0.0));
    assert!(sun > 1000.0 * zenith_ish, "sun pdf {sun}, sky {zenith_ish}");
}

/// `shadenet gen sky` writes the committed map with its defaults, and refuses a bad size or
/// sun with an error naming the option.
#[test]
fn gen_sky_writes_the_map_and_refuses_bad_parameters() {
    let dir = tmp_dir("gen");
    let out = dir.join("sky.hdr");
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_shadenet"))
            .args(["gen", "sky", "-o"])
            .arg(&out)
            .args(args)
            .output()
            .unwrap()
    };
    assert!(run(&[]).status.success());
    let committed =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/pbr_sky.hdr"))
            .unwrap();
    assert!(std::fs::read(&out).unwrap() == committed);
    for (args, want) in [
        (
            &["--width", "0"][..],
            "--width/--height: the image is empty",
        ),
        (&["--height", "20000"][..], "too large"),
        (
            &["--sun-elevation", "120"][..],
            "--sun-elevation 120: must be -90 to 90",
        ),
        (&["--sun-radius", "0"][..], "--sun-radius 0"),
    ] {
        let o = run(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(want), "{args:?}: {err}");
    }
    // The refused runs left the written map as it was.
    assert!(std::fs::read(&out).unwrap() == committed);
}
