//! The texture system's files: every format decoded by its color space, clear errors naming
//! the file for missing, truncated, corrupt and huge-header files, UDIM sets, and the cache's
//! sharing and budget. Every asset is generated here.

use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, Image, WritableImage, f16};
use shadenet_graph::ir::{ColorSpace, Filter, Sampling, TextureFile, Wrap};
use shadenet_runtime::texture::cache::{self, Cache};
use shadenet_runtime::texture::colorspace::{Conversion, Transfer};
use shadenet_runtime::texture::mip::Pyramid;
use shadenet_runtime::{Texture, TextureSet, rgbe};
use std::path::{Path, PathBuf};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shadenet-texfiles-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn open(path: &Path, colorspace: ColorSpace) -> Texture {
    Texture::load(&TextureFile {
        path: path.to_string_lossy().into_owned(),
        colorspace,
    })
    .unwrap()
}

fn open_err(path: &Path, colorspace: ColorSpace) -> String {
    Texture::load(&TextureFile {
        path: path.to_string_lossy().into_owned(),
        colorspace,
    })
    .unwrap_err()
    .to_string()
}

/// The sRGB decoding of the texture system before color spaces (image's `to_rgba32f`, then
/// this curve in f32), to check 8-bit PNGs decode bit for bit as before.
fn old_srgb(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        shadenet_graph::ops::math::pow_f32((c + 0.055) / 1.055, 2.4)
    }
}

#[test]
fn png_8_bit_decodes_by_color_space_and_as_before() {
    let d = dir("png8");
    let p = d.join("ramp.png");
    // 256 × 1 RGBA: red, green, blue and alpha are the code, 255 − code, code/2, code.
    let px: Vec<u8> = (0..=255u8).flat_map(|b| [b, 255 - b, b / 2, b]).collect();
    image::save_buffer(&p, &px, 256, 1, image::ExtendedColorType::Rgba8).unwrap();
    let before = image::open(&p).unwrap().to_rgba32f();
    let t = open(&p, ColorSpace::Auto);
    assert_eq!((t.width(), t.height()), (256, 1));
    for (i, (got, old)) in t.texels().iter().zip(before.pixels()).enumerate() {
        let [r, g, b, a] = old.0;
        let want = [old_srgb(r), old_srgb(g), old_srgb(b), a];
        assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "code {i}");
    }
    // Raw: the codes over 255, nothing else.
    let raw = open(&p, ColorSpace::Raw);
    assert_eq!(
        raw.texels()[200],
        [200.0 / 255.0, 55.0 / 255.0, 100.0 / 255.0, 200.0 / 255.0]
    );
    // g22_rec709 and acescg: the transfer, then the matrix; alpha untouched.
    let g22 = open(&p, ColorSpace::G22Rec709);
    let want = Transfer::Gamma(2.2).decode(200.0 / 255.0);
    assert_eq!(g22.texels()[200][0], want);
    assert_eq!(g22.texels()[200][3], 200.0 / 255.0);
    let aces = open(&p, ColorSpace::AcesCg);
    let conv = Conversion::of(ColorSpace::AcesCg, false);
    let want = conv.apply_matrix([200.0 / 255.0, 55.0 / 255.0, 100.0 / 255.0]);
    assert_eq!(&aces.texels()[200][..3], &want);
    assert_eq!(aces.texels()[200][3], 200.0 / 255.0);
}

#[test]
fn png_16_bit_grey_and_jpeg() {
    let d = dir("png16");
    let p = d.join("grey16.png");
    // 2 × 1 grey + alpha, 16 bits: (32768, 65535) and (1000, 0).
    let px: Vec<u8> = [32768u16, 65535, 1000, 0]
        .iter()
        .flat_map(|v| v.to_be_bytes())
        .collect();
    // save_buffer takes native-endian u16 samples as bytes.
    let native: Vec<u8> = px
        .chunks(2)
        .flat_map(|c| u16::from_be_bytes([c[0], c[1]]).to_ne_bytes())
        .collect();
    image::save_buffer(&p, &native, 2, 1, image::ExtendedColorType::La16).unwrap();
    let t = open(&p, ColorSpace::Auto);
    let y = Transfer::Srgb.decode(32768.0 / 65535.0);
    assert_eq!(t.texels()[0], [y, y, y, 1.0]);
    let y = Transfer::Srgb.decode(1000.0 / 65535.0);
    assert_eq!(t.texels()[1], [y, y, y, 0.0]);

    let j = d.join("solid.jpg");
    let px: Vec<u8> = (0..16 * 16).flat_map(|_| [200u8, 100, 50]).collect();
    let mut f = std::fs::File::create(&j).unwrap();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut f, 100)
        .encode(&px, 16, 16, image::ExtendedColorType::Rgb8)
        .unwrap();
    drop(f);
    let t = open(&j, ColorSpace::Auto);
    for (c, code) in [200.0f32, 100.0, 50.0].iter().enumerate() {
        let want = Transfer::Srgb.decode(code / 255.0);
        let tol = Transfer::Srgb.decode((code + 2.0) / 255.0) - want;
        assert!(
            (t.texels()[17][c] - want).abs() <= tol,
            "{c}: {:?}",
            t.texels()[17]
        );
    }
}

#[test]
fn radiance_hdr_is_linear_by_default() {
    let d = dir("hdr");
    let p = d.join("sky.hdr");
    let texels: Vec<[f32; 3]> = (0..15)
        .map(|i| [i as f32 * 0.5, 1.0 / (i + 1) as f32, 3.0])
        .collect();
    let bytes = rgbe::write_hdr(5, 3, &texels);
    std::fs::write(&p, &bytes).unwrap();
    let (_, _, want) = rgbe::read(&bytes, |_, _| Ok(())).unwrap();
    let t = open(&p, ColorSpace::Auto);
    assert_eq!((t.width(), t.height()), (5, 3));
    for (got, want) in t.texels().iter().zip(&want) {
        assert_eq!(got, &[want[0], want[1], want[2], 1.0]);
    }
    // An explicit color space applies: acescg's matrix.
    let t = open(&p, ColorSpace::AcesCg);
    let conv = Conversion::of(ColorSpace::AcesCg, true);
    assert_eq!(&t.texels()[4][..3], &conv.apply_matrix(want[4]));
}

fn write_exr(path: &Path, w: usize, h: usize, channels: Vec<(&str, FlatSamples)>) {
    let list = channels
        .into_iter()
        .map(|(name, samples)| AnyChannel::new(name, samples))
        .collect();
    let image = Image::from_channels((w, h), AnyChannels::sort(list));
    image.write().to_file(path).unwrap();
}

#[test]
fn openexr_half_float_rgba_rgb_and_single_channel() {
    let d = dir("exr");
    let (w, h) = (3usize, 2usize);
    let vals: Vec<f32> = (0..w * h).map(|i| i as f32 * 0.25 - 0.5).collect();
    let half = |k: f32| FlatSamples::F16(vals.iter().map(|v| f16::from_f32(v * k)).collect());
    let float = |k: f32| FlatSamples::F32(vals.iter().map(|v| v * k).collect());
    // Half RGBA.
    let p = d.join("rgba_half.exr");
    write_exr(
        &p,
        w,
        h,
        vec![
            ("R", half(1.0)),
            ("G", half(2.0)),
            ("B", half(4.0)),
            ("A", half(-1.0)),
        ],
    );
    let t = open(&p, ColorSpace::Auto);
    for (i, v) in vals.iter().enumerate() {
        assert_eq!(t.texels()[i], [*v, v * 2.0, v * 4.0, -v], "texel {i}");
    }
    // Float RGB: alpha 1.
    let p = d.join("rgb_float.exr");
    write_exr(
        &p,
        w,
        h,
        vec![("R", float(1.0)), ("G", float(3.0)), ("B", float(0.5))],
    );
    let t = open(&p, ColorSpace::Auto);
    for (i, v) in vals.iter().enumerate() {
        assert_eq!(t.texels()[i], [*v, v * 3.0, v * 0.5, 1.0], "texel {i}");
    }
    // Y: grey.
    let p = d.join("y.exr");
    write_exr(&p, w, h, vec![("Y", float(1.0))]);
    let t = open(&p, ColorSpace::Auto);
    assert_eq!(t.texels()[5], [vals[5], vals[5], vals[5], 1.0]);
    // Any single channel (a mask), half.
    let p = d.join("mask.exr");
    write_exr(&p, w, h, vec![("mask", half(1.0))]);
    let t = open(&p, ColorSpace::Raw);
    assert_eq!(t.texels()[4], [vals[4], vals[4], vals[4], 1.0]);
    // A layer's channels: diffuse.R, diffuse.G, diffuse.B.
    let p = d.join("layer.exr");
    write_exr(
        &p,
        w,
        h,
        vec![
            ("diffuse.R", float(1.0)),
            ("diffuse.G", float(1.0)),
            ("diffuse.B", float(2.0)),
            ("Z", float(9.0)),
        ],
    );
    let t = open(&p, ColorSpace::Auto);
    assert_eq!(t.texels()[3], [vals[3], vals[3], vals[3] * 2.0, 1.0]);
    // Two unrelated channels: nothing to read, said so.
    let p = d.join("zw.exr");
    write_exr(&p, w, h, vec![("Z", float(1.0)), ("W", float(1.0))]);
    let e = open_err(&p, ColorSpace::Auto);
    assert!(e.contains("zw.exr") && e.contains("no R, G and B"), "{e}");
}

/// CRC-32 (PNG's) of a chunk's type and data.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xedb8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend((data.len() as u32).to_be_bytes());
    let mut body = kind.to_vec();
    body.extend(data);
    out.extend(&body);
    out.extend(crc32(&body).to_be_bytes());
}

#[test]
fn bad_files_are_clear_errors_naming_the_file() {
    let d = dir("bad");
    // Missing.
    let p = d.join("missing.png");
    let e = open_err(&p, ColorSpace::Auto);
    assert!(
        e.starts_with(&format!("cannot load texture {}", p.display())),
        "{e}"
    );
    // A directory.
    let e = open_err(&d, ColorSpace::Auto);
    assert!(e.contains("not a regular file"), "{e}");
    // Not an image.
    let p = d.join("text.png");
    std::fs::write(&p, "hello, world").unwrap();
    let e = open_err(&p, ColorSpace::Auto);
    assert!(
        e.contains("text.png") && e.contains("not a PNG, JPEG"),
        "{e}"
    );
    // Truncated PNG.
    let p = d.join("cut.png");
    let px: Vec<u8> = (0..64 * 64 * 3).map(|i| (i * 31 % 251) as u8).collect();
    image::save_buffer(&p, &px, 64, 64, image::ExtendedColorType::Rgb8).unwrap();
    let bytes = std::fs::read(&p).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    let e = open_err(&p, ColorSpace::Auto);
    assert!(e.contains("cut.png"), "{e}");
    // A PNG header of 10⁶ × 10⁶ texels (valid CRCs): refused from the header.
    let p = d.join("huge.png");
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = 1_000_000u32.to_be_bytes().to_vec();
    ihdr.extend(1_000_000u32.to_be_bytes());
    ihdr.extend([8, 6, 0, 0, 0]);
    chunk(&mut png, b"IHDR", &ihdr);
    chunk(
        &mut png,
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    );
    chunk(&mut png, b"IEND", &[]);
    std::fs::write(&p, &png).unwrap();
    let e = open_err(&p, ColorSpace::Auto);
    assert!(
        e.contains("huge.png") && e.contains("1000000×1000000"),
        "{e}"
    );
    // The same for Radiance HDR.
    let p = d.join("huge.hdr");
    std::fs::write(
        &p,
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1000000 +X 1000000\n\x02\x02",
    )
    .unwrap();
    let e = open_err(&p, ColorSpace::Auto);
    assert!(
        e.contains("huge.hdr") && e.contains("1000000×1000000"),
        "{e}"
    );
    // A truncated HDR.
    let p = d.join("cut.hdr");
    let mut bytes = rgbe::write_hdr(16, 8, &[[1.0; 3]; 128]);
    bytes.truncate(bytes.len() - 40);
    std::fs::write(&p, &bytes).unwrap();
    let e = open_err(&p, ColorSpace::Auto);
    assert!(e.contains("cut.hdr") && e.contains("ends early"), "{e}");
    // An EXR whose data window says 10⁶ × 10⁶.
    let p = d.join("huge.exr");
    write_exr(&p, 2, 2, vec![("Y", FlatSamples::F32(vec![1.0; 4]))]);
    let mut bytes = std::fs::read(&p).unwrap();
    let at = bytes
        .windows(17)
        .position(|w| w == b"dataWindow\0box2i\0")
        .expect("the data window attribute")
        + 17
        + 4;
    bytes[at + 8..at + 12].copy_from_slice(&999_999i32.to_le_bytes());
    bytes[at + 12..at + 16].copy_from_slice(&999_999i32.to_le_bytes());
    std::fs::write(&p, &bytes).unwrap();
    let e = open_err(&p, ColorSpace::Auto);
    assert!(e.contains("huge.exr"), "{e}");
    // A truncated EXR.
    let p = d.join("cut.exr");
    write_exr(&p, 16, 16, vec![("Y", FlatSamples::F32(vec![1.0; 256]))]);
    let bytes = std::fs::read(&p).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() - 300]).unwrap();
    let e = open_err(&p, ColorSpace::Auto);
    assert!(e.contains("cut.exr"), "{e}");
    // A set fails on its first bad file, naming it.
    let good = d.join("good.png");
    image::save_buffer(&good, &[1u8, 2, 3], 1, 1, image::ExtendedColorType::Rgb8).unwrap();
    let files = [
        TextureFile::auto(good.to_string_lossy()),
        TextureFile::auto(d.join("cut.png").to_string_lossy()),
    ];
    let e = TextureSet::load(&files).unwrap_err().to_string();
    assert!(e.contains("cut.png"), "{e}");
}

fn solid_png(path: &Path, rgb: [u8; 3]) {
    let px: Vec<u8> = (0..4).flat_map(|_| rgb).collect();
    image::save_buffer(path, &px, 2, 2, image::ExtendedColorType::Rgb8).unwrap();
}

#[test]
fn udim_tiles_by_uv() {
    let d = dir("udim");
    solid_png(&d.join("wall.1001.png"), [255, 0, 0]);
    solid_png(&d.join("wall.1002.png"), [0, 255, 0]);
    solid_png(&d.join("wall.1011.png"), [0, 0, 255]);
    solid_png(&d.join("wall.1999.png"), [255, 255, 255]);
    // Not tiles: other names.
    solid_png(&d.join("wall.10021.png"), [9, 9, 9]);
    solid_png(&d.join("wall.0999.png"), [9, 9, 9]);
    let pattern = d.join("wall.<UDIM>.png");
    let t = open(&pattern, ColorSpace::Raw);
    let tiles: Vec<u32> = t.udim_tiles().unwrap().iter().map(|(n, _)| *n).collect();
    assert_eq!(tiles, vec![1001, 1002, 1011, 1999]);
    let s = Sampling {
        filter: Filter::Anisotropic,
        wrap: [Wrap::Clamp; 2],
    };
    let look = |u: f64, v: f64| t.lookup([u, v], [[0.01, 0.0], [0.0, 0.01]], s);
    assert_eq!(look(0.5, 0.5), [1.0, 0.0, 0.0, 1.0]);
    assert_eq!(look(1.25, 0.75), [0.0, 1.0, 0.0, 1.0]);
    assert_eq!(look(0.5, 1.5), [0.0, 0.0, 1.0, 1.0]);
    assert_eq!(look(8.5, 99.5), [1.0, 1.0, 1.0, 1.0]);
    // Missing tiles and off the grid: black.
    for (u, v) in [
        (2.5, 0.5),
        (-0.5, 0.5),
        (10.5, 0.5),
        (0.5, -0.1),
        (0.5, 100.5),
        (f64::NAN, 0.5),
    ] {
        assert_eq!(look(u, v), [0.0; 4], "({u}, {v})");
    }
    // No tile at all; the marker in a directory.
    let e = open_err(&d.join("floor.<UDIM>.png"), ColorSpace::Auto);
    assert!(
        e.contains("floor.<UDIM>.png") && e.contains("no UDIM tile exists"),
        "{e}"
    );
    let e = open_err(&d.join("<UDIM>").join("x.png"), ColorSpace::Auto);
    assert!(e.contains("must be in the file name"), "{e}");
}

#[test]
fn materials_share_one_decoded_pyramid() {
    let d = dir("share");
    let p = d.join("shared.png");
    solid_png(&p, [10, 20, 30]);
    let a = open(&p, ColorSpace::Auto);
    let before = cache::stats();
    // Another material, another spelling of the same path.
    let b = open(&d.join(".").join("shared.png"), ColorSpace::Auto);
    let after = cache::stats();
    assert!(std::ptr::eq(a.pyramid(), b.pyramid()));
    assert!(after.cache_hits > before.cache_hits);
    // Another color space is another entry.
    let c = open(&p, ColorSpace::Raw);
    assert!(!std::ptr::eq(a.pyramid(), c.pyramid()));
    assert_eq!(c.texels()[0][0], 10.0 / 255.0);
    // The file rewritten (another size): decoded again.
    let px: Vec<u8> = (0..9).flat_map(|_| [40u8, 50, 60]).collect();
    image::save_buffer(&p, &px, 3, 3, image::ExtendedColorType::Rgb8).unwrap();
    let e = open(&p, ColorSpace::Raw);
    assert_eq!(e.width(), 3);
    assert_eq!(e.texels()[0][0], 40.0 / 255.0);
    assert!(format!("{}", cache::stats()).starts_with("textures: "));
}

#[test]
fn the_budget_evicts_only_what_no_material_holds() {
    let d = dir("budget");
    let files: Vec<PathBuf> = (0..4)
        .map(|i| {
            let p = d.join(format!("t{i}.png"));
            let px: Vec<u8> = (0..16 * 16 * 3).map(|k| (k + i) as u8).collect();
            image::save_buffer(&p, &px, 16, 16, image::ExtendedColorType::Rgb8).unwrap();
            p
        })
        .collect();
    let one = Pyramid::bytes_for(16, 16);
    let mut c = Cache::new(2 * one + one / 2);
    let a = cache::open_in(&mut c, &files[0], ColorSpace::Auto).unwrap();
    let b = cache::open_in(&mut c, &files[1], ColorSpace::Auto).unwrap();
    // Both held: the third goes over the budget rather than evict a live texture.
    let t2 = cache::open_in(&mut c, &files[2], ColorSpace::Auto).unwrap();
    let s = c.stats();
    assert_eq!(
        (s.files_opened, s.evictions, s.bytes_resident),
        (3, 0, 3 * one)
    );
    assert_eq!(s.peak_bytes, 3 * one);
    // Released: a (least recently used) and t2; b stays held. The fourth evicts a and t2.
    drop(a);
    drop(t2);
    let _d = cache::open_in(&mut c, &files[3], ColorSpace::Auto).unwrap();
    let s = c.stats();
    assert_eq!(
        (s.files_opened, s.evictions, s.bytes_resident),
        (4, 2, 2 * one)
    );
    // b is still resident: a hit, the same pyramid.
    let b2 = cache::open_in(&mut c, &files[1], ColorSpace::Auto).unwrap();
    assert!(std::sync::Arc::ptr_eq(&b, &b2));
    assert_eq!(c.stats().cache_hits, 1);
    // A texture larger than the whole budget is refused before decoding, naming the file.
    let big = d.join("big.png");
    let px = vec![7u8; 64 * 64 * 3];
    image::save_buffer(&big, &px, 64, 64, image::ExtendedColorType::Rgb8).unwrap();
    let e = cache::open_in(&mut c, &big, ColorSpace::Auto)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("big.png") && e.contains("texture memory budget"),
        "{e}"
    );
}
