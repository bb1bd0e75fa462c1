//! MaterialX atoms that read derivatives or a tangent frame: `heighttonormal` and the
//! library's `bump` graph over it (procedural and image heights — a texture's derivative
//! is a difference over the footprint), and the hex-tiling lookups `hextiledimage` and
//! `hextilednormalmap` against an f64 transcription of MaterialX 1.39's `mx_hextile.osl`.
//! Needs the MaterialX libraries (fails without them when `CI` is set, skips otherwise).

mod common;
use common::*;
use shadenet::graph::error_chain;
use shadenet::graph::ir::{ColorSpace, Filter, Sampling, TextureFile, Wrap};
use shadenet::graph::mtlx::{self, Selection};
use shadenet_runtime::Fragment;
use shadenet_runtime::texture::Texture;

fn compile(body: &str) -> Option<shadenet::Compiled> {
    let lib = mtlx_library()?;
    let src =
        format!("<?xml version=\"1.0\"?>\n<materialx version=\"1.39\">\n{body}\n</materialx>\n");
    Some(
        mtlx::compile("t.mtlx", &src, lib, &Selection::default())
            .unwrap_or_else(|e| panic!("{}\n{src}", error_chain(&e))),
    )
}

/// The plane fragment at `uv` with screen-space derivatives `dpdx`, `dpdy` (the plane's
/// dP/du, dP/dv are the x and y axes, so these are uv's derivatives too).
fn at(uv: [f32; 2], dpdx: [f32; 3], dpdy: [f32; 3]) -> Fragment {
    Fragment {
        uv,
        dpdx,
        dpdy,
        ..plane_fragment()
    }
}

/// A linear height `a·u + b·v` from the uv stream.
const LINEAR_HEIGHT: &str = r#"
  <texcoord name="uv" type="vector2" />
  <dotproduct name="h" type="float">
    <input name="in1" type="vector2" nodename="uv" />
    <input name="in2" type="vector2" value="3.0, -5.0" />
  </dotproduct>"#;

fn unit(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / l)
}

/// `heighttonormal` of `a·u + b·v` is `normalize(−a·s/16, −b·s/16, 1)` encoded in [0, 1],
/// whatever the footprint's size and orientation (a mirrored footprint too); flat without
/// ray differentials.
#[test]
fn heighttonormal_is_the_height_fields_normal() {
    let body = format!(
        r#"{LINEAR_HEIGHT}
  <heighttonormal name="n" type="vector3">
    <input name="in" type="float" nodename="h" />
    <input name="scale" type="float" value="4.0" />
  </heighttonormal>
  <output name="out" type="vector3" nodename="n" />"#
    );
    let Some(c) = compile(&body) else { return };
    let s = 4.0 / 16.0;
    let want = unit([-3.0 * s, 5.0 * s, 1.0]).map(|x| x * 0.5 + 0.5);
    let footprints = [
        ([0.01, 0.0, 0.0], [0.0, 0.01, 0.0]),
        ([0.002, 0.003, 0.0], [-0.004, 0.001, 0.0]),
        // Mirrored: x and y swapped.
        ([0.0, 0.01, 0.0], [0.01, 0.0, 0.0]),
        ([30.0, 2.0, 0.0], [1.0, 40.0, 0.0]),
    ];
    for (dx, dy) in footprints {
        let o = run_program(&c.program, &at([0.3, 0.7], dx, dy), &[], u32::MAX);
        assert_close(
            &o.get("out"),
            &want,
            1e-6,
            &format!("footprint {dx:?} {dy:?}"),
        );
    }
    let o = run_program(&c.program, &plane_fragment(), &[], u32::MAX);
    assert_close(&o.get("out"), &[0.5, 0.5, 1.0], 0.0, "no differentials");
}

/// `bump` (the library's graph: heighttonormal → normalmap) on the plane bends N against
/// the height's gradient; its `scale` scales the tangent-plane part.
#[test]
fn bump_bends_the_normal_against_the_gradient() {
    let body = format!(
        r#"{LINEAR_HEIGHT}
  <bump name="b" type="vector3">
    <input name="height" type="float" nodename="h" />
    <input name="scale" type="float" value="0.5" />
  </bump>
  <output name="out" type="vector3" nodename="b" />"#
    );
    let Some(c) = compile(&body) else { return };
    let d = unit([-3.0 / 16.0, 5.0 / 16.0, 1.0]);
    let want = unit([d[0] * 0.5, d[1] * 0.5, d[2]]);
    let f = at([0.5, 0.5], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0]);
    let o = run_program(&c.program, &f, &[], u32::MAX);
    assert_close(&o.get("out"), &want, 1e-6, "bump");
}

/// A `w`×`h` RGB8 PNG in a fresh folder, texel (x, y) from `f`; its path.
fn png(name: &str, w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> String {
    let d = std::env::temp_dir().join(format!("shadenet-tiling-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join("t.png");
    let mut px = Vec::new();
    for y in 0..h {
        for x in 0..w {
            px.extend(f(x, y));
        }
    }
    image::save_buffer(&p, &px, w, h, image::ExtendedColorType::Rgb8).unwrap();
    p.to_string_lossy().into_owned()
}

/// The height of an image, black to white left to right (2×1 texels, clamped): between the
/// texel centres `h = 2u − 0.5`, so its normal is `normalize(−2·s/16, 0, 1)` — the
/// lookup's derivative is a difference of two filtered lookups.
#[test]
fn heighttonormal_differentiates_an_image() {
    let file = png("ramp", 2, 1, |x, _| [255 * x as u8; 3]);
    let body = format!(
        r#"<image name="h" type="float">
    <input name="file" type="filename" value="{file}" />
    <input name="uaddressmode" type="string" value="clamp" />
  </image>
  <heighttonormal name="n" type="vector3">
    <input name="in" type="float" nodename="h" />
    <input name="scale" type="float" value="8.0" />
  </heighttonormal>
  <output name="out" type="vector3" nodename="n" />"#
    );
    let Some(c) = compile(&body) else { return };
    let want = unit([-2.0 * 8.0 / 16.0, 0.0, 1.0]).map(|x| x * 0.5 + 0.5);
    let f = at([0.5, 0.5], [0.002, 0.0, 0.0], [0.0, 0.002, 0.0]);
    let o = run_program(&c.program, &f, &[], u32::MAX);
    assert_close(&o.get("out"), &want, 1e-5, "image height");
}

// ---- hex tiling: an f64 transcription of MaterialX 1.39's mx_hextile.osl ----

fn fract(x: f64) -> f64 {
    x - x.floor()
}

fn mix(a: f64, b: f64, t: f64) -> f64 {
    a * (1.0 - t) + b * t
}

fn hash(p: [f64; 2]) -> [f64; 2] {
    let mut q = [p[0] * 0.1031, p[1] * 0.1030, p[0] * 0.0973].map(fract);
    let d = q[0] * (q[1] + 33.33) + q[1] * (q[2] + 33.33) + q[2] * (q[0] + 33.33);
    q = q.map(|x| x + d);
    [fract((q[0] + q[1]) * q[2]), fract((q[0] + q[2]) * q[1])]
}

struct Params {
    tiling: [f64; 2],
    rotation: f64,
    rotation_range: [f64; 2],
    scale: f64,
    scale_range: [f64; 2],
    offset: f64,
    offset_range: [f64; 2],
    falloff: f64,
}

/// `mx_hextile_coord`: the three tiles' coordinates, weights and rotations.
fn hextile(coord: [f64; 2], p: &Params) -> ([[f64; 2]; 3], [f64; 3], [f64; 3]) {
    let k = 3f64.sqrt() * 2.0;
    let st = [coord[0] * k, coord[1] * k];
    let sk = [st[0] + st[1] * -0.57735027, st[1] * 1.15470054];
    let fr = [fract(sk[0]), fract(sk[1])];
    let z = 1.0 - fr[0] - fr[1];
    let s = if -z >= 0.0 { 1.0 } else { 0.0 };
    let s2 = 2.0 * s - 1.0;
    let w = [-z * s2, s - fr[1] * s2, s - fr[0] * s2];
    let (bx, by) = (sk[0].floor(), sk[1].floor());
    let ids = [
        (bx + s, by + s),
        (bx + s, by + 1.0 - s),
        (bx + 1.0 - s, by + s),
    ];
    let rr = p.rotation_range.map(f64::to_radians);
    let mut coords = [[0.0; 2]; 3];
    let mut rots = [0.0; 3];
    for (i, (ix, iy)) in ids.into_iter().enumerate() {
        let ctr = [(ix + iy * 0.5) / k, (iy / 1.15470054) / k];
        let r = hash([ix + 0.12345, iy + 0.12345]);
        let rot = mix(rr[0], rr[1], r[0] * p.rotation);
        let sc = mix(1.0, mix(p.scale_range[0], p.scale_range[1], r[1]), p.scale);
        let off = [
            mix(p.offset_range[0], p.offset_range[1], r[0] * p.offset),
            mix(p.offset_range[0], p.offset_range[1], r[1] * p.offset),
        ];
        let d = [coord[0] - ctr[0], coord[1] - ctr[1]];
        let (c, sn) = (rot.cos(), rot.sin());
        coords[i] = [
            (d[0] * c - d[1] * sn) / sc + ctr[0] + off[0],
            (d[0] * sn + d[1] * c) / sc + ctr[1] + off[1],
        ];
        rots[i] = rot;
    }
    (coords, w, rots)
}

fn gain(x: f64, r: f64) -> f64 {
    let rr = r.clamp(0.001, 0.999);
    let a = (1.0 / rr - 2.0) * (1.0 - 2.0 * x);
    if x < 0.5 {
        x / (a + 1.0)
    } else {
        (a - x) / (a - 1.0)
    }
}

fn blend_weights(lum: [f64; 3], tw: [f64; 3], falloff: f64) -> [f64; 3] {
    let norm = |w: [f64; 3]| {
        let s = w[0] + w[1] + w[2];
        w.map(|x| x / s)
    };
    let w = norm([0, 1, 2].map(|i| lum[i] * tw[i].powf(7.0)));
    if falloff == 0.5 {
        w
    } else {
        norm(w.map(|x| gain(x, falloff)))
    }
}

const PARAMS: &str = r#"
    <input name="tiling" type="vector2" value="3.0, 2.0" />
    <input name="rotationrange" type="vector2" value="-40.0, 300.0" />
    <input name="scale" type="float" value="0.8" />
    <input name="scalerange" type="vector2" value="0.6, 1.7" />
    <input name="offset" type="float" value="0.9" />
    <input name="offsetrange" type="vector2" value="0.1, 0.8" />
    <input name="falloff" type="float" value="FALLOFF" />"#;

fn params(falloff: f64) -> Params {
    Params {
        tiling: [3.0, 2.0],
        rotation: 1.0,
        rotation_range: [-40.0, 300.0],
        scale: 0.8,
        scale_range: [0.6, 1.7],
        offset: 0.9,
        offset_range: [0.1, 0.8],
        falloff,
    }
}

/// A 16×16 texture of distinct colours in its own file `name` (tests run in parallel: a
/// shared file raced), and its runtime texture for the reference.
fn tile_texture(name: &str) -> (String, Texture) {
    let file = png(name, 16, 16, |x, y| {
        [
            (x * 16) as u8,
            (y * 16) as u8,
            ((x * 7 + y * 3) % 16 * 16) as u8,
        ]
    });
    let t = Texture::load(&TextureFile {
        path: file.clone(),
        colorspace: ColorSpace::LinRec709,
    })
    .unwrap();
    (file, t)
}

/// The reference lookups: periodic, no footprint (the fragments have no differentials).
fn look(t: &Texture, uv: [f64; 2]) -> [f64; 4] {
    let sampling = Sampling {
        filter: Filter::Anisotropic,
        wrap: [Wrap::Periodic; 2],
    };
    t.lookup(uv, [[0.0; 2]; 2], sampling)
}

const UVS: [[f32; 2]; 6] = [
    [0.13, 0.27],
    [0.5, 0.5],
    [0.91, 0.04],
    [-1.37, 2.61],
    [7.25, -3.5],
    [0.333, 0.667],
];

/// `hextiledimage` (colour3 and colour4) equals the transcription, with and without a
/// falloff, at points in and far outside [0, 1]².
#[test]
fn hextiledimage_matches_materialx() {
    let (file, tex) = tile_texture("tile-image");
    for falloff in [0.5, 0.3] {
        let body = format!(
            r#"<hextiledimage name="img" type="color4">
    <input name="file" type="filename" value="{file}" />{}
    <input name="falloffcontrast" type="float" value="0.7" />
  </hextiledimage>
  <output name="out" type="color4" nodename="img" />"#,
            PARAMS.replace("FALLOFF", &falloff.to_string())
        );
        let Some(c) = compile(&body) else { return };
        let p = params(falloff);
        let luma = [0.2722287, 0.6740818, 0.0536895];
        for uv in UVS {
            let o = run_program(&c.program, &at(uv, [0.0; 3], [0.0; 3]), &[], u32::MAX);
            let coord = [uv[0] as f64 * p.tiling[0], uv[1] as f64 * p.tiling[1]];
            let (coords, tw, _) = hextile(coord, &p);
            let cs = coords.map(|c| look(&tex, c));
            let lum = cs.map(|c| mix(1.0, c[0] * luma[0] + c[1] * luma[1] + c[2] * luma[2], 0.7));
            let w = blend_weights(lum, tw, p.falloff);
            let aw = blend_weights([1.0; 3], tw, p.falloff);
            let mut want = [0.0; 4];
            for i in 0..3 {
                for k in 0..3 {
                    want[k] += w[i] * cs[i][k];
                }
                want[3] += aw[i] * cs[i][3];
            }
            assert_close(
                &o.get("out"),
                &want,
                1e-5,
                &format!("uv {uv:?} falloff {falloff}"),
            );
        }
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn axpy(a: f64, x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|k| a * x[k] + y[k])
}

/// `transform(mx_axis_rotation_matrix(axis, −angle), v)` with OSL's row vectors.
fn rotate(v: [f64; 3], a: [f64; 3], angle: f64) -> [f64; 3] {
    let (s, c) = (-angle).sin_cos();
    let omc = 1.0 - c;
    let m = [
        [
            a[0] * a[0] * omc + c,
            a[0] * a[1] * omc - a[2] * s,
            a[0] * a[2] * omc + a[1] * s,
        ],
        [
            a[1] * a[0] * omc + a[2] * s,
            a[1] * a[1] * omc + c,
            a[1] * a[2] * omc - a[0] * s,
        ],
        [
            a[2] * a[0] * omc - a[1] * s,
            a[2] * a[1] * omc + a[0] * s,
            a[2] * a[2] * omc + c,
        ],
    ];
    [0, 1, 2].map(|j| v[0] * m[0][j] + v[1] * m[1][j] + v[2] * m[2][j])
}

/// `hextilednormalmap` equals the transcription (tiles decoded in their rotated tangent
/// frames, blended as surface gradients), `flip_g` on; the tilted frame makes the
/// Gram–Schmidt steps count.
#[test]
fn hextilednormalmap_matches_materialx() {
    let (file, tex) = tile_texture("tile-normal");
    let n = unit([0.2, -0.1, 1.0]);
    let t = unit([1.0, 0.3, 0.0]);
    let b = unit(cross(n, t));
    let v = |x: [f64; 3]| format!("{}, {}, {}", x[0], x[1], x[2]);
    let body = format!(
        r#"<hextilednormalmap name="nm" type="vector3">
    <input name="file" type="filename" value="{file}" />{}
    <input name="strength" type="float" value="0.7" />
    <input name="flip_g" type="boolean" value="true" />
    <input name="normal" type="vector3" value="{}" />
    <input name="tangent" type="vector3" value="{}" />
    <input name="bitangent" type="vector3" value="{}" />
  </hextilednormalmap>
  <output name="out" type="vector3" nodename="nm" />"#,
        PARAMS.replace("FALLOFF", "0.35"),
        v(n),
        v(t),
        v(b)
    );
    let Some(c) = compile(&body) else { return };
    let p = params(0.35);
    for uv in UVS {
        let o = run_program(&c.program, &at(uv, [0.0; 3], [0.0; 3]), &[], u32::MAX);
        let coord = [uv[0] as f64 * p.tiling[0], uv[1] as f64 * p.tiling[1]];
        let (coords, tw, rots) = hextile(coord, &p);
        let normals: Vec<[f64; 3]> = (0..3)
            .map(|i| {
                let c = look(&tex, coords[i]);
                let nm = [c[0], 1.0 - c[1], c[2]].map(|x| 2.0 * x - 1.0);
                let ti = rotate(t, n, rots[i]).map(|x| x * 0.7);
                let bi = rotate(b, n, rots[i]).map(|x| x * 0.7);
                let tn = unit(axpy(-dot(ti, n), n, ti));
                let bn = unit(axpy(-dot(bi, tn), tn, axpy(-dot(bi, n), n, bi)));
                unit(axpy(nm[2], n, axpy(nm[1], bn, tn.map(|x| x * nm[0]))))
            })
            .collect();
        let w = blend_weights([1.0; 3], tw, p.falloff);
        let mut gg = [0.0; 3];
        for i in 0..3 {
            let d = dot(n, normals[i]);
            let g = axpy(-1.0, normals[i], n.map(|x| x * d)).map(|x| x / d.abs().max(1e-8));
            gg = axpy(w[i].clamp(0.0, 1.0), g, gg);
        }
        let want = unit(axpy(-1.0, gg, n));
        assert_close(&o.get("out"), &want, 1e-5, &format!("uv {uv:?}"));
    }
}

/// Without a file: `default` (hextiledimage) and the `normal` input (hextilednormalmap),
/// as MaterialX's implementations return.
#[test]
fn hextiled_nodes_without_a_file() {
    let body = r#"<hextiledimage name="img" type="color3">
    <input name="default" type="color3" value="0.25, 0.5, 0.75" />
  </hextiledimage>
  <output name="out" type="color3" nodename="img" />"#;
    let Some(c) = compile(body) else { return };
    let o = run_program(&c.program, &plane_fragment(), &[], u32::MAX);
    assert_close(&o.get("out"), &[0.25, 0.5, 0.75], 0.0, "image default");
    let body = r#"<hextilednormalmap name="nm" type="vector3" />
  <output name="out" type="vector3" nodename="nm" />"#;
    let Some(c) = compile(body) else { return };
    let o = run_program(&c.program, &plane_fragment(), &[], u32::MAX);
    assert_close(&o.get("out"), &[0.0, 0.0, 1.0], 0.0, "normal map default");
}
