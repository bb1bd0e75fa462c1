//! The texture system's speed (issue 16): filtered lookups from a warm cache on one thread
//! (trilinear, anisotropic at anisotropy 4 and 16, bilinear for scale), f32 as the renderer
//! calls them, over 4096 precomputed (uv, derivatives) pairs on a 1024² texture, in a
//! renderer's coherent order and shuffled; and the load
//! of a 4096² half RGBA OpenEXR (ZIP, 16 scanlines per block) with its mipmaps built.
//! `cargo bench -p shadenet-runtime --bench texture`; `cargo test --benches` runs a quick
//! check instead.

use criterion::{Criterion, Throughput, criterion_group};
use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Image, WritableImage, f16};
use shadenet_graph::ir::{ColorSpace, Filter, Sampling, TextureFile, Wrap};
use shadenet_runtime::Texture;
use shadenet_runtime::texture::cache;
use std::hint::black_box;
use std::path::{Path, PathBuf};

/// Lookups per measured iteration.
const LOOKUPS: usize = 4096;

/// A half RGBA EXR of `n × n` texels: gradients with a hashed speckle (so ZIP does not
/// shrink it to nothing).
fn write_exr(path: &Path, n: usize) {
    let speckle = |i: usize| ((i.wrapping_mul(2_654_435_761) >> 7) & 0xff) as f32 / 2550.0;
    let channel = |name: &str, f: &dyn Fn(usize, usize) -> f32| {
        let samples = (0..n * n)
            .map(|i| f16::from_f32(f(i % n, i / n) + speckle(i)))
            .collect();
        AnyChannel::new(name, FlatSamples::F16(samples))
    };
    let k = 1.0 / n as f32;
    let list = vec![
        channel("R", &|x, _| x as f32 * k),
        channel("G", &|_, y| y as f32 * k),
        channel("B", &|x, y| ((x ^ y) & 63) as f32 / 63.0),
        channel("A", &|_, _| 1.0),
    ];
    let image = Image::from_encoded_channels(
        (n, n),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list.into_iter().collect()),
    );
    image.write().to_file(path).unwrap();
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shadenet-bench-texture-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// Deterministic (uv, duv) pairs as a renderer asks them: 16 patches of 16 × 16 pixels, each a
/// planar view of the texture (uv advancing by the derivatives from pixel to pixel, so
/// neighbours read neighbouring texels) at a random place, angle and scale: footprints
/// `minor` (1 to 16) texels across and `minor × anisotropy` along. `shuffled`: the same
/// lookups in a random order (every lookup a cache miss: memory latency, not filtering).
fn footprints(n: f32, anisotropy: f32, shuffled: bool) -> Vec<([f32; 2], [[f32; 2]; 2])> {
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut v = Vec::with_capacity(LOOKUPS);
    for _ in 0..LOOKUPS / 256 {
        let base = [next() * 4.0 - 2.0, next() * 4.0 - 2.0];
        let minor = (1.0 + 15.0 * next()) / n;
        let major = minor * anisotropy;
        // A rotation without the platform's sin/cos: the rational parametrization by
        // t = tan(angle/2), angles in [−90°, 90°].
        let t = next() * 2.0 - 1.0;
        let (c, si) = ((1.0 - t * t) / (1.0 + t * t), 2.0 * t / (1.0 + t * t));
        let duv = [[minor * c, minor * si], [-major * si, major * c]];
        for j in 0..16 {
            for i in 0..16 {
                let (x, y) = (i as f32, j as f32);
                let uv = [
                    base[0] + x * duv[0][0] + y * duv[1][0],
                    base[1] + x * duv[0][1] + y * duv[1][1],
                ];
                v.push((uv, duv));
            }
        }
    }
    if shuffled {
        for i in (1..v.len()).rev() {
            let j = (next() * (i + 1) as f32) as usize % (i + 1);
            v.swap(i, j);
        }
    }
    v
}

fn run(t: &Texture, s: Sampling, f: &[([f32; 2], [[f32; 2]; 2])]) -> f32 {
    let mut acc = 0.0;
    for (uv, duv) in f {
        acc += t.lookup(*uv, *duv, s)[0];
    }
    acc
}

fn sampling(filter: Filter) -> Sampling {
    Sampling {
        filter,
        wrap: [Wrap::Periodic; 2],
    }
}

fn bench(c: &mut Criterion) {
    let small = temp("warm_1024.exr");
    write_exr(&small, 1024);
    let t = Texture::load(&TextureFile::auto(small.to_string_lossy())).unwrap();
    let mut g = c.benchmark_group("texture_lookup_f32_warm");
    g.throughput(Throughput::Elements(LOOKUPS as u64));
    for (order, shuffled) in [("coherent", false), ("shuffled", true)] {
        let iso = footprints(1024.0, 1.0, shuffled);
        let a4 = footprints(1024.0, 4.0, shuffled);
        let a16 = footprints(1024.0, 16.0, shuffled);
        let cases = [
            ("bilinear", Filter::Bilinear, &iso),
            ("trilinear", Filter::Trilinear, &iso),
            ("anisotropic_4", Filter::Anisotropic, &a4),
            ("anisotropic_16", Filter::Anisotropic, &a16),
        ];
        for (name, filter, f) in cases {
            g.bench_function(format!("{name}_{order}"), |b| {
                b.iter(|| black_box(run(&t, sampling(filter), f)))
            });
        }
    }
    g.finish();

    let big = temp("load_4096.exr");
    write_exr(&big, 4096);
    let budget = cache::budget_bytes().unwrap();
    let mut g = c.benchmark_group("texture_load");
    g.sample_size(10);
    g.bench_function("exr_4096_half_rgba_zip_with_mipmaps", |b| {
        b.iter(|| black_box(cache::load(&big, ColorSpace::Auto, budget).unwrap().bytes()))
    });
    g.finish();
    let _ = std::fs::remove_dir_all(big.parent().unwrap());
}

criterion_group!(benches, bench);

fn main() {
    if !std::env::args().any(|a| a == "--bench") {
        let p = temp("smoke_64.exr");
        write_exr(&p, 64);
        let t = Texture::load(&TextureFile::auto(p.to_string_lossy())).unwrap();
        assert_eq!(t.pyramid().levels().len(), 7);
        for filter in [Filter::Bilinear, Filter::Trilinear, Filter::Anisotropic] {
            assert!(run(&t, sampling(filter), &footprints(64.0, 4.0, true)).is_finite());
        }
        let _ = std::fs::remove_dir_all(p.parent().unwrap());
        println!(
            "texture bench smoke check: ok (run `cargo bench -p shadenet-runtime --bench texture`)"
        );
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
