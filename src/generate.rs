//! Generated networks for benchmarks and tests (DESIGN §9), written by `shadenet gen`.
//!
//! [`mult_tree`] is benchmark B1, the multiplication tree of Larsson (2005, §5.1.1): a
//! balanced binary tree of `2^n − 1` `multiply` nodes over `2^n` leaves, each leaf its own
//! `samplerInfo` node whose position `P` (in world or camera space) feeds the bottom row, and
//! the root feeding the material output `color`. Since every leaf reads the fragment, nothing
//! folds away: the tree measures the cost of passing data between nodes and from the renderer
//! to the shading system.
//!
//! [`sky`] is a procedural lat-long environment map (a sky gradient, a small bright sun disc
//! with a glow around it and a darker ground), the light of `examples/scenes/pbr.toml`:
//! written as a Radiance `.hdr` by [`sky_hdr`], it is the committed `pbr_sky.hdr`.

use serde_json::{Map, Value, json};
use shadenet_graph::ir::Space;
use shadenet_graph::nodes::env_image::{check_size, uv_to_direction};
use shadenet_graph::ops::math;
use std::ops::RangeInclusive;

/// The levels a multiplication tree may have: level 16 is 65 535 multiplies over 65 536
/// leaves, far beyond the thesis's level 10.
pub const MULT_TREE_LEVELS: RangeInclusive<u32> = 1..=16;

/// A network that cannot be generated.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum GenError {
    /// The tree's level is outside [`MULT_TREE_LEVELS`].
    #[error(
        "a multiplication tree has {} to {} levels, not {levels}",
        MULT_TREE_LEVELS.start(),
        MULT_TREE_LEVELS.end()
    )]
    Levels {
        /// The level asked for.
        levels: u32,
    },
    /// A sky parameter is out of range (the message names it).
    #[error("{0}")]
    Sky(String),
    /// The test texture could not be encoded.
    #[error("cannot encode the test texture: {0}")]
    Texture(String),
}

/// The parameters of [`sky`]; the defaults make the committed `examples/scenes/pbr_sky.hdr`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sky {
    /// Width in texels (the height's double for square texels).
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// The sun's elevation above the horizon, degrees (−90 to 90).
    pub sun_elevation: f64,
    /// The sun's azimuth, degrees: 0 at the map's centre column (−z before the light's
    /// rotation), 90 at +x (`u = 0.75`).
    pub sun_azimuth: f64,
    /// The sun disc's angular radius, degrees (above 0, at most 45).
    pub sun_radius: f64,
    /// The sun disc's radiance (finite, ≥ 0); the sky's is about 0.2 to 0.8.
    pub sun_radiance: f64,
}

impl Default for Sky {
    fn default() -> Sky {
        Sky {
            width: 256,
            height: 128,
            sun_elevation: 35.0,
            sun_azimuth: 0.0,
            sun_radius: 2.0,
            sun_radiance: 1000.0,
        }
    }
}

/// Supersamples per texel side: each texel is the mean of 4 × 4 point samples.
const SKY_SUPERSAMPLES: u32 = 4;

/// The radiance of the procedural sky in unit direction `d` (map frame, +y up), with the
/// sun in unit direction `sun`.
fn sky_radiance(p: &Sky, d: [f64; 3], sun: [f64; 3]) -> [f64; 3] {
    let lerp = |a: [f64; 3], b: [f64; 3], t: f64| -> [f64; 3] {
        std::array::from_fn(|c| a[c] + (b[c] - a[c]) * t)
    };
    let zenith = [0.16, 0.30, 0.72];
    let horizon = [0.72, 0.80, 0.95];
    let ground = [0.10, 0.085, 0.07];
    let y = d[1];
    let sky = lerp(zenith, horizon, math::pow(1.0 - y.max(0.0), 4.0));
    // Below the horizon, the ground, blended over 3° into half the horizon's light.
    let base = if y >= 0.0 {
        sky
    } else {
        let t = (-y / 0.05).min(1.0);
        lerp(horizon.map(|c| 0.5 * c), ground, t)
    };
    let cos_a = (d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2]).clamp(-1.0, 1.0);
    let a = math::acos(cos_a).to_degrees();
    // A warm glow of 10° around the sun, then the disc.
    let glow = 2.5 * math::exp(-(a / 10.0) * (a / 10.0));
    let mut c: [f64; 3] = std::array::from_fn(|i| base[i] + glow * [1.0, 0.85, 0.6][i]);
    if a <= p.sun_radius {
        c = [1.0, 0.93, 0.82].map(|x| x * p.sun_radiance);
    }
    c
}

/// The procedural sky of `p` as lat-long texels (rows from the top, the orientation of
/// `shadenet_graph::nodes::env_image`), each the mean of 4 × 4 point samples. Deterministic:
/// f64 with our own `sin`, `cos`, `acos`, `exp` and `pow`, rounded once to f32.
pub fn sky(p: &Sky) -> Result<Vec<[f32; 3]>, GenError> {
    check_size(p.width, p.height).map_err(|m| GenError::Sky(format!("--width/--height: {m}")))?;
    let bad =
        |name: &str, v: f64, range: &str| GenError::Sky(format!("--{name} {v}: must be {range}"));
    if !(p.sun_elevation.is_finite() && p.sun_elevation.abs() <= 90.0) {
        return Err(bad("sun-elevation", p.sun_elevation, "-90 to 90 degrees"));
    }
    if !p.sun_azimuth.is_finite() {
        return Err(bad(
            "sun-azimuth",
            p.sun_azimuth,
            "a finite number of degrees",
        ));
    }
    if !(p.sun_radius > 0.0 && p.sun_radius <= 45.0) {
        return Err(bad(
            "sun-radius",
            p.sun_radius,
            "above 0 and at most 45 degrees",
        ));
    }
    if !(p.sun_radiance.is_finite() && (0.0..=1e30).contains(&p.sun_radiance)) {
        return Err(bad("sun-radiance", p.sun_radiance, "0 to 1e30"));
    }
    let (e, az) = (p.sun_elevation.to_radians(), p.sun_azimuth.to_radians());
    let (ce, se) = (math::cos(e), math::sin(e));
    // The map frame's direction of azimuth φ: (sin φ, ·, −cos φ).
    let sun = [math::sin(az) * ce, se, -math::cos(az) * ce];
    let (w, h) = (p.width as usize, p.height as usize);
    let n = SKY_SUPERSAMPLES;
    let mut texels = Vec::with_capacity(w * h);
    for j in 0..h {
        for i in 0..w {
            let mut sum = [0.0f64; 3];
            for sj in 0..n {
                for si in 0..n {
                    let u = (i as f64 + (si as f64 + 0.5) / n as f64) / w as f64;
                    let v = (j as f64 + (sj as f64 + 0.5) / n as f64) / h as f64;
                    let (d, _) = uv_to_direction([u, v], (1.0, 0.0));
                    let c = sky_radiance(p, d, sun);
                    sum.iter_mut().zip(c).for_each(|(s, x)| *s += x);
                }
            }
            texels.push(sum.map(|s| (s / (n * n) as f64) as f32));
        }
    }
    Ok(texels)
}

/// [`sky`] as a Radiance `.hdr` file (run-length encoded RGBE).
pub fn sky_hdr(p: &Sky) -> Result<Vec<u8>, GenError> {
    let texels = sky(p)?;
    Ok(shadenet_tracer::envmap::write_hdr(
        p.width, p.height, &texels,
    ))
}

/// The side of [`test_texture`] in texels.
pub const TEST_TEXTURE_SIZE: u32 = 2048;

/// The texel `(x, y)` (row 0 at the top) of [`test_texture`], sRGB-encoded: 16-texel checks
/// of two shades whose hue changes every 256 texels (an 8 × 8 palette), crossed by one-texel
/// dark lines every 128 texels. High frequencies at every scale: unfiltered at a grazing
/// angle it aliases into moiré, filtered it fades to each block's mean.
pub fn test_texel(x: u32, y: u32) -> [u8; 3] {
    if x.is_multiple_of(128) || y.is_multiple_of(128) {
        return [20, 20, 24];
    }
    let (bx, by) = (x / 256, y / 256);
    // A hue per block: the 8 × 8 blocks walk the colour wheel in a scrambled order.
    let k = (bx * 5 + by * 3) % 8;
    const HUES: [[u8; 3]; 8] = [
        [230, 80, 60],
        [240, 170, 50],
        [200, 220, 70],
        [80, 200, 90],
        [60, 190, 200],
        [70, 110, 230],
        [150, 80, 220],
        [220, 90, 170],
    ];
    let hue = HUES[k as usize];
    if (x / 16 + y / 16).is_multiple_of(2) {
        hue
    } else {
        hue.map(|c| (c as u32 * 2 / 5) as u8)
    }
}

/// The texture of `examples/scenes/texture_plane.toml`: [`test_texel`] over a
/// [`TEST_TEXTURE_SIZE`]² image, as PNG bytes (8-bit sRGB).
pub fn test_texture() -> Result<Vec<u8>, GenError> {
    let n = TEST_TEXTURE_SIZE;
    let mut px = Vec::with_capacity((n * n * 3) as usize);
    for y in 0..n {
        for x in 0..n {
            px.extend(test_texel(x, y));
        }
    }
    let mut out = Vec::new();
    let enc = image::codecs::png::PngEncoder::new_with_quality(
        &mut out,
        image::codecs::png::CompressionType::Best,
        image::codecs::png::FilterType::Adaptive,
    );
    image::ImageEncoder::write_image(enc, &px, n, n, image::ExtendedColorType::Rgb8)
        .map_err(|e| GenError::Texture(e.to_string()))?;
    Ok(out)
}

/// The multiplication-tree network of `levels` levels (benchmark B1), as network JSON
/// (`docs/network-format.md`), with leaves reading `P` in `space`.
///
/// Nodes are named by position: leaf `p<i>` (`i` in `0..2^levels`) is a `samplerInfo` with
/// `space` set; `m<l>_<i>` (`l` in `1..=levels`, `i` in `0..2^(levels − l)`) is a `multiply`
/// of the product of the `2^l` leaves `p<i·2^l>` … `p<(i+1)·2^l − 1>`: `m1_<i>` multiplies
/// `p<2i>.P` by `p<2i+1>.P`, and `m<l>_<i>` multiplies `m<l−1>_<2i>.out` by
/// `m<l−1>_<2i+1>.out`. The root `m<levels>_0` is the output `color` (a vec3: `P^(2^levels)`
/// component-wise, multiplied in tree order). Leaves come first in the node list, then the
/// rows bottom-up. The network is named `mult_tree_<levels>_<space>`.
pub fn mult_tree(levels: u32, space: Space) -> Result<Value, GenError> {
    if !MULT_TREE_LEVELS.contains(&levels) {
        return Err(GenError::Levels { levels });
    }
    let leaves = 1usize << levels;
    let mut nodes = Vec::with_capacity(2 * leaves - 1);
    for i in 0..leaves {
        nodes.push(json!({
            "name": format!("p{i}"),
            "type": "samplerInfo",
            "inputs": { "space": space.name() },
        }));
    }
    for l in 1..=levels {
        for i in 0..leaves >> l {
            let (a, b) = if l == 1 {
                (format!("p{}.P", 2 * i), format!("p{}.P", 2 * i + 1))
            } else {
                (
                    format!("m{}_{}.out", l - 1, 2 * i),
                    format!("m{}_{}.out", l - 1, 2 * i + 1),
                )
            };
            nodes.push(json!({
                "name": format!("m{l}_{i}"),
                "type": "multiply",
                "inputs": { "input1": a, "input2": b },
            }));
        }
    }
    let mut outputs = Map::new();
    outputs.insert("color".into(), Value::String(format!("m{levels}_0.out")));
    Ok(json!({
        "name": format!("mult_tree_{levels}_{}", space.name()),
        "version": 1,
        "nodes": nodes,
        "outputs": outputs,
    }))
}

/// [`mult_tree`] written as an RSL surface shader (world space): one `point` local per
/// multiply, the leaves `P`, the root converted to `Ci` (RSL has no point-to-color
/// assignment: three `xcomp`-style extracts and a constructor).
pub fn mult_tree_sl(levels: u32) -> Result<String, GenError> {
    if !MULT_TREE_LEVELS.contains(&levels) {
        return Err(GenError::Levels { levels });
    }
    let leaves = 1usize << levels;
    let mut s = format!(
        "/* Benchmark B1 (Larsson 2005, §5.1.1) as a shader: {} multiplies over {leaves} leaves. */\nsurface mult_tree_{levels}()\n{{\n",
        leaves - 1
    );
    for l in 1..=levels {
        for i in 0..leaves >> l {
            let (a, b) = if l == 1 {
                ("P".to_string(), "P".to_string())
            } else {
                (
                    format!("m{}_{}", l - 1, 2 * i),
                    format!("m{}_{}", l - 1, 2 * i + 1),
                )
            };
            s += &format!("    point m{l}_{i} = {a} * {b};\n");
        }
    }
    s += &format!(
        "    Ci = color \"rgb\" (xcomp(m{levels}_0), ycomp(m{levels}_0), zcomp(m{levels}_0));\n}}\n"
    );
    Ok(s)
}

/// The shaders of [`mult_tree_group`]: a leaf reading `P` and a multiply, as `(file name,
/// source)`.
pub const MULT_TREE_SHADERS: [(&str, &str); 2] = [
    (
        "mt_leaf.osl",
        "// Benchmark B1's leaf as an OSL layer: P as a color.\nshader mt_leaf(output color out = 0) { out = color(P[0], P[1], P[2]); }\n",
    ),
    (
        "mt_mult.osl",
        "// Benchmark B1's multiply as an OSL layer.\nshader mt_mult(color a = 0, color b = 0, output color out = 0) { out = a * b; }\n",
    ),
];

/// [`mult_tree`] as an OSL shader group in OSL's serialized text: 2^N leaf layers and
/// 2^N − 1 multiply layers (2047 layers at level 10), connected as the network's nodes are;
/// the shaders are [`MULT_TREE_SHADERS`], written beside it.
pub fn mult_tree_group(levels: u32) -> Result<String, GenError> {
    if !MULT_TREE_LEVELS.contains(&levels) {
        return Err(GenError::Levels { levels });
    }
    let leaves = 1usize << levels;
    let mut s = format!(
        "// Benchmark B1 (Larsson 2005, §5.1.1) as an OSL shader group: {} layers.\n",
        2 * leaves - 1
    );
    for i in 0..leaves {
        s += &format!("shader mt_leaf p{i} ;\n");
    }
    for l in 1..=levels {
        for i in 0..leaves >> l {
            s += &format!("shader mt_mult m{l}_{i} ;\n");
            let (a, b) = if l == 1 {
                (format!("p{}", 2 * i), format!("p{}", 2 * i + 1))
            } else {
                (
                    format!("m{}_{}", l - 1, 2 * i),
                    format!("m{}_{}", l - 1, 2 * i + 1),
                )
            };
            s += &format!("connect {a}.out m{l}_{i}.a ;\nconnect {b}.out m{l}_{i}.b ;\n");
        }
    }
    Ok(s)
}

/// The grid cells per side of [`vertex_color_obj`]'s mesh.
pub const VERTEX_COLOR_GRID: u32 = 8;

/// A Wavefront OBJ mesh with vertex colours (the `v x y z r g b` extension), the mesh of
/// `examples/scenes/vertex_colors.toml` (the committed `examples/scenes/meshes/vertex_colors.obj`):
/// the square [−1, 1]² in the plane z = 0, facing +z, as a grid of
/// [`VERTEX_COLOR_GRID`]² cells (two triangles each), uv from (0, 0) at (−1, −1). The colour
/// of the vertex at grid uv (u, v) is (u, v, 1 − u·v) with every other vertex of the middle
/// row and column darkened to a quarter, so that interpolation across a triangle shows.
/// Numbers are written with 6 decimals: the text is the same on every platform.
pub fn vertex_color_obj() -> String {
    let n = VERTEX_COLOR_GRID;
    let mut s = String::from(
        "# Generated by `shadenet gen vertex-colors`: a plane with vertex colours\n\
         # (v x y z r g b), read as attribute COLOR_0.\n",
    );
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
            let mut c = [u, v, 1.0 - u * v];
            if (i == n / 2 || j == n / 2) && (i + j) % 2 == 1 {
                c = c.map(|x| x * 0.25);
            }
            s += &format!(
                "v {:.6} {:.6} 0.000000 {:.6} {:.6} {:.6}\n",
                2.0 * u - 1.0,
                2.0 * v - 1.0,
                c[0],
                c[1],
                c[2]
            );
        }
    }
    for j in 0..=n {
        for i in 0..=n {
            s += &format!("vt {:.6} {:.6}\n", i as f64 / n as f64, j as f64 / n as f64);
        }
    }
    s += "vn 0 0 1\n";
    let row = n + 1;
    for j in 0..n {
        for i in 0..n {
            let a = j * row + i + 1;
            let (b, c, d) = (a + 1, a + row + 1, a + row);
            s += &format!("f {a}/{a}/1 {b}/{b}/1 {c}/{c}/1\nf {a}/{a}/1 {c}/{c}/1 {d}/{d}/1\n");
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tree_links_with_the_thesis_node_counts() {
        for level in 1..=4 {
            let net = mult_tree(level, Space::World).unwrap().to_string();
            assert_eq!(net.matches("\"multiply\"").count(), (1 << level) - 1);
            assert_eq!(net.matches("\"samplerInfo\"").count(), 1 << level);
            let c = shadenet_graph::compile_json(&net, &shadenet_graph::NodeLibrary::standard())
                .unwrap();
            shadenet_graph::ir::validate(&c.program).unwrap();
        }
    }
}
