//! The JIT batch entry's noise helpers (issue 23): `fbm3` of B7's network (6 octaves,
//! lacunarity 2.1, gain 0.55) over 640×480 points, four lanes at a time — per lane through the
//! scalar function (what the batch entry did before `ops::noise_x4`), and through
//! `fbm3_x4` on each SIMD path the CPU has; then the same for OSL's generators that the
//! MaterialX noise nodes call (`ops::osl_noise` per lane against `ops::osl_noise_x4`):
//! `perlin3`, `fractal3` (the same 6 octaves, 2.1, 0.55), `cell3` and `worley3` (jitter 1,
//! Euclidean distance); and OSL's vector simplex noise (`osl_vsimplex3_640x480`). One
//! thread. `cargo bench --bench noise`; `cargo test --benches` runs a quick check that the
//! paths agree instead.

use criterion::{Criterion, criterion_group};
use shadenet::graph::ops::noise_x4::{self, Path};
use shadenet::graph::ops::{noise, osl_noise, osl_noise_x4, osl_simplex};
use std::hint::black_box;

const W: usize = 640;
const H: usize = 480;

/// The points of a 640×480 grid on the unit plane, scaled by 3 (B7's network), as packets.
fn packets() -> Vec<[[f32; 4]; 3]> {
    let mut v = Vec::new();
    for y in 0..H {
        for x0 in (0..W).step_by(4) {
            let x = [0, 1, 2, 3].map(|l| ((x0 + l) as f32 + 0.5) / W as f32 * 3.0 - 1.5);
            let y = [(1.0 - (y as f32 + 0.5) / H as f32) * 3.0 - 1.5; 4];
            v.push([x, y, [0.0; 4]]);
        }
    }
    v
}

fn per_lane(ps: &[[[f32; 4]; 3]]) -> f32 {
    let mut acc = 0.0;
    for p in ps {
        for ((x, y), z) in p[0].iter().zip(&p[1]).zip(&p[2]) {
            acc += noise::fbm3::<f32>([*x, *y, *z], 6, 2.1, 0.55);
        }
    }
    acc
}

fn four_lanes(path: Path, ps: &[[[f32; 4]; 3]]) -> f32 {
    let mut acc = 0.0;
    for p in ps {
        let r = noise_x4::fbm3_x4_on(path, *p, [6; 4], [2.1; 4], [0.55; 4]);
        for x in r {
            acc += x;
        }
    }
    acc
}

/// An OSL generator's benchmark: the scalar function per lane and the four-lane form on a
/// path, each summed over the packets.
struct Osl {
    name: &'static str,
    scalar: fn([f32; 3]) -> f32,
    x4: fn(Path, [[f32; 4]; 3]) -> [f32; 4],
}

const OSL: [Osl; 4] = [
    Osl {
        name: "osl_perlin3_640x480",
        scalar: osl_noise::perlin3::<f32>,
        x4: osl_noise_x4::perlin3_x4_on,
    },
    Osl {
        name: "osl_fractal3_640x480",
        scalar: |p| osl_noise::fractal3::<f32>(p, 6, 2.1, 0.55),
        x4: |path, p| osl_noise_x4::fractal3_x4_on(path, p, [6; 4], [2.1; 4], [0.55; 4]),
    },
    Osl {
        name: "osl_cell3_640x480",
        scalar: osl_noise::cell3::<f32>,
        x4: osl_noise_x4::cell3_x4_on,
    },
    Osl {
        name: "osl_worley3_640x480",
        scalar: |p| osl_noise::worley3::<f32>(p, 1.0, 0, 0),
        x4: |path, p| osl_noise_x4::worley3_x4_on(path, p, [1.0; 4], [0; 4], [0; 4]),
    },
];

impl Osl {
    fn per_lane(&self, ps: &[[[f32; 4]; 3]]) -> f32 {
        let mut acc = 0.0;
        for [x, y, z] in ps {
            for ((x, y), z) in x.iter().zip(y).zip(z) {
                acc += (self.scalar)([*x, *y, *z]);
            }
        }
        acc
    }

    fn four_lanes(&self, path: Path, ps: &[[[f32; 4]; 3]]) -> f32 {
        let mut acc = 0.0;
        for p in ps {
            for x in (self.x4)(path, *p) {
                acc += x;
            }
        }
        acc
    }
}

fn bench_osl(c: &mut Criterion, ps: &[[[f32; 4]; 3]]) {
    for o in &OSL {
        let mut g = c.benchmark_group(o.name);
        g.sample_size(10);
        g.bench_function("per_lane_scalar", |b| b.iter(|| black_box(o.per_lane(ps))));
        for path in [Path::Lanes, Path::Base, Path::Sse41, Path::Avx2] {
            if path.available() {
                g.bench_function(format!("x4_{path:?}"), |b| {
                    b.iter(|| black_box(o.four_lanes(path, ps)))
                });
            }
        }
        g.finish();
    }
}

/// OSL's vector simplex noise (`vector noise("simplex", p)`) over the grid: three float
/// noises at seeds 0, 1, 2 (what it computed before, as OSL's own code does) against the
/// vector noise that walks the lattice once for the three seeds (the same bits).
fn bench_vsimplex(c: &mut Criterion, ps: &[[[f32; 4]; 3]]) {
    let points = || {
        ps.iter()
            .flat_map(|p| (0..4).map(move |l| [p[0][l], p[1][l], p[2][l] + 0.37 * p[0][l]]))
    };
    let mut g = c.benchmark_group("osl_vsimplex3_640x480");
    g.sample_size(10);
    g.bench_function("three_float_noises", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for p in points() {
                for s in 0..3 {
                    acc += osl_simplex::simplex3(p, s);
                }
            }
            black_box(acc)
        })
    });
    g.bench_function("vector_noise", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for p in points() {
                acc += osl_simplex::vsimplex3(p).iter().sum::<f32>();
            }
            black_box(acc)
        })
    });
    g.finish();
}

fn bench(c: &mut Criterion) {
    let ps = packets();
    bench_vsimplex(c, &ps);
    let mut g = c.benchmark_group("fbm3_640x480");
    g.sample_size(20);
    g.bench_function("per_lane_scalar", |b| b.iter(|| black_box(per_lane(&ps))));
    for path in [Path::Lanes, Path::Base, Path::Sse41, Path::Avx2] {
        if path.available() {
            g.bench_function(format!("x4_{path:?}"), |b| {
                b.iter(|| black_box(four_lanes(path, &ps)))
            });
        }
    }
    g.finish();
    bench_osl(c, &ps);
}

criterion_group!(benches, bench);

fn main() {
    if !std::env::args().any(|a| a == "--bench") {
        let ps: Vec<_> = packets().into_iter().step_by(97).collect();
        let want = per_lane(&ps);
        for path in [Path::Base, Path::Sse41, Path::Avx2] {
            if path.available() {
                assert_eq!(four_lanes(path, &ps).to_bits(), want.to_bits(), "{path:?}");
            }
        }
        for o in &OSL {
            let want = o.per_lane(&ps);
            for path in [Path::Base, Path::Sse41, Path::Avx2] {
                if path.available() {
                    let got = o.four_lanes(path, &ps);
                    assert_eq!(got.to_bits(), want.to_bits(), "{} {path:?}", o.name);
                }
            }
        }
        println!("noise bench smoke check: ok (run `cargo bench --bench noise`)");
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
