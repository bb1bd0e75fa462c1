//! Filtered noise and fractals (`shadenet_graph::nodes::filtered_noise`): the octaves finer
//! than the footprint dropped, measured against a brute-force supersampled box over the
//! footprint; the unfiltered bits where the footprint is fine or absent; the unfiltered
//! program where filtering is off; interpreter and JIT (scalar and batch) bit for bit.

use shadenet::graph::ir::{Builder, Intrinsic, Program, Stream};
use shadenet::graph::ops::{noise, osl_noise};
use shadenet::graph::opt::{self, Specialization};
use shadenet::graph::types::Type;
use shadenet_jit::JitBackend;
use shadenet_runtime::{
    Backend, Fragment, InterpBackend, Interpreter, ShadeCtx, ShadeEnv, shade_batch,
};
use std::time::Duration;

/// The program of a network (JSON) on the standard node library.
fn network(src: &str) -> Program {
    shadenet::compile_json(src, &shadenet::NodeLibrary::standard())
        .unwrap()
        .program
}

/// A `fractal` (6 octaves, lacunarity 2, gain 0.5) of `P`, its `outAlpha`, with `filter`.
fn fractal(filter: f64) -> Program {
    network(&format!(
        r#"{{"nodes": [{{"name": "f", "type": "fractal",
              "inputs": {{"octaves": 6, "filter": {filter}}}}}],
            "outputs": {{"f": "f.outAlpha"}}}}"#
    ))
}

/// A `solidNoise` of `P`, its `outAlpha`, with `filter`.
fn solid_noise(filter: f64) -> Program {
    network(&format!(
        r#"{{"nodes": [{{"name": "n", "type": "solidNoise", "inputs": {{"filter": {filter}}}}}],
            "outputs": {{"n": "n.outAlpha"}}}}"#
    ))
}

/// A fragment at `p` whose screen axes move P by `dpdx` and `dpdy`.
fn at(p: [f64; 3], dpdx: [f64; 3], dpdy: [f64; 3]) -> Fragment {
    Fragment {
        p: p.map(|x| x as f32),
        dpdx: dpdx.map(|x| x as f32),
        dpdy: dpdy.map(|x| x as f32),
        n: [0.0, 0.0, 1.0],
        ng: [0.0, 0.0, 1.0],
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        ..Fragment::default()
    }
}

/// The first output of `p` at `f`, in f64.
fn eval64(p: &Program, f: Fragment) -> f64 {
    let env = ShadeEnv::default();
    Interpreter::<f64>::new(p)
        .unwrap()
        .shade(&ShadeCtx::new(f, &env))
        .values[0]
}

/// Every output of `p` at `f` in f32 and f64, as bits.
fn bits(p: &Program, f: Fragment) -> (Vec<u32>, Vec<u64>) {
    let env = ShadeEnv::default();
    let ctx = ShadeCtx::new(f, &env);
    let a = Interpreter::<f32>::new(p).unwrap().shade(&ctx).values;
    let b = Interpreter::<f64>::new(p).unwrap().shade(&ctx).values;
    (
        a.iter().map(|x| x.to_bits()).collect(),
        b.iter().map(|x| x.to_bits()).collect(),
    )
}

/// A deterministic point in [0, 16)³ (a small LCG; no RNG crate in tests).
fn point(i: u64) -> [f64; 3] {
    let mut s = i
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    [0; 3].map(|_| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64 * 16.0
    })
}

/// A skewed footprint of scale `w`: the two screen axes move P by about `w` each, not
/// orthogonally and partly off the xy plane.
fn footprint(w: f64) -> ([f64; 3], [f64; 3]) {
    ([0.8 * w, 0.6 * w, 0.0], [-0.3 * w, 0.7 * w, 0.65 * w])
}

/// The box average of `f` over the parallelogram `p + a·dpdx + b·dpdy`, `a, b ∈ [−½, ½]`,
/// from `n × n` samples.
fn box_average(f: impl Fn([f64; 3]) -> f64, p: [f64; 3], dx: [f64; 3], dy: [f64; 3]) -> f64 {
    let n = 48;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let a = (i as f64 + 0.5) / n as f64 - 0.5;
            let b = (j as f64 + 0.5) / n as f64 - 0.5;
            sum += f([0, 1, 2].map(|k| p[k] + a * dx[k] + b * dy[k]));
        }
    }
    sum / (n * n) as f64
}

/// RMS errors of the filtered and of the unfiltered (point-sampled) program against the
/// box average of `unfiltered` over the footprint of scale `w`, over 48 points.
fn errors(filtered: &Program, unfiltered: impl Fn([f64; 3]) -> f64 + Copy, w: f64) -> (f64, f64) {
    let (dx, dy) = footprint(w);
    let (mut ef, mut eu) = (0.0, 0.0);
    let m = 48;
    for i in 0..m {
        let p = point(i);
        let want = box_average(unfiltered, p, dx, dy);
        let got = eval64(filtered, at(p, dx, dy));
        ef += (got - want).powi(2);
        eu += (unfiltered(p) - want).powi(2);
    }
    ((ef / m as f64).sqrt(), (eu / m as f64).sqrt())
}

/// `outAlpha` of the unfiltered 6-octave `fractal` at `p`.
fn fbm(p: [f64; 3]) -> f64 {
    0.5 + 0.5 * noise::fbm3(p, 6, 2.0, 0.5)
}

/// Measured (f64 interpreter, 48 points in [0, 16)³, skewed footprints whose axes are `w`
/// long, 48² box samples): RMS error of `outAlpha` against the box average, filtered vs
/// unfiltered: w = 0.05: 0.0027 vs 0.0046; w = 0.25: 0.0170 vs 0.0267; w = 1: 0.0464 vs
/// 0.1036; w = 4: 0.0260 vs 0.1373 (there every octave is dropped: the flat average 0.5).
#[test]
fn filtered_fractal_is_closer_to_the_box_average() {
    let prog = fractal(1.0);
    for (w, at_most) in [(0.05, 0.7), (0.25, 0.75), (1.0, 0.55), (4.0, 0.25)] {
        let (f, u) = errors(&prog, fbm, w);
        eprintln!("fractal w {w}: filtered {f:.4} unfiltered {u:.4}");
        assert!(f <= at_most * u, "w {w}: filtered {f} vs unfiltered {u}");
    }
}

/// Measured as the fractal's, single-octave `solidNoise`: w = 0.25: 0.0050 vs 0.0060;
/// w = 1: 0.0387 vs 0.0621; w = 4: 0.0259 vs 0.1074.
#[test]
fn filtered_noise_fades_to_its_average() {
    let prog = solid_noise(1.0);
    let n = |p: [f64; 3]| 0.5 + 0.5 * noise::noise3(p);
    for (w, at_most) in [(0.25, 0.9), (1.0, 0.7), (4.0, 0.3)] {
        let (f, u) = errors(&prog, n, w);
        eprintln!("solidNoise w {w}: filtered {f:.4} unfiltered {u:.4}");
        assert!(f <= at_most * u, "w {w}: filtered {f} vs unfiltered {u}");
    }
    // A footprint of many lattice cells is the average, exactly.
    let (dx, dy) = footprint(8.0);
    assert_eq!(eval64(&prog, at([1.3, 2.7, 0.4], dx, dy)), 0.5);
}

#[test]
fn fine_or_absent_footprints_give_the_unfiltered_bits() {
    let (on, off) = (fractal(1.0), fractal(0.0));
    let (n_on, n_off) = (solid_noise(1.0), solid_noise(0.0));
    // 6 octaves of lacunarity 2 stay whole up to a footprint of 0.1 / 2⁵ = 0.003125.
    for w in [0.0, 1e-4, 0.003, f64::NAN] {
        for i in 0..32 {
            let (dx, dy) = footprint(w);
            let f = at(point(i), dx, dy);
            assert_eq!(bits(&on, f), bits(&off, f), "fractal w {w}");
            assert_eq!(bits(&n_on, f), bits(&n_off, f), "solidNoise w {w}");
        }
    }
    // And the unfiltered program is the plain fbm.
    let f = at([1.3, 2.7, 0.4], [0.0; 3], [0.0; 3]);
    assert_eq!(
        eval64(&off, f),
        fbm([1.3f32 as f64, 2.7f32 as f64, 0.4f32 as f64])
    );
    // A coarser footprint does change the result: the filter is on.
    let (dx, dy) = footprint(0.1);
    let f = at([1.3, 2.7, 0.4], dx, dy);
    assert_ne!(bits(&on, f), bits(&off, f));
}

/// The optimized program of `p`, as text, without its name and its parameter table (the
/// network declares its inputs there; baked, they are constants in the body).
fn optimized(p: &Program) -> String {
    let text = opt::run(p, &Specialization::default()).0.to_string();
    text.lines()
        .skip(1)
        .filter(|l| !l.trim_start().starts_with("param "))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The lowering of `fractal` before filtering: `0.5 + 0.5 · fbm3(P · 1, 6, 2, 0.5)`.
fn plain_fractal() -> Program {
    let mut b = Builder::new("network");
    let p = b.stream(Stream::P);
    let one = b.float(1.0);
    let s = b.splat(Type::Vec3, one);
    let q = b.mul(p, s);
    let (o, l, g) = (b.int(6), b.float(2.0), b.float(0.5));
    let n = b.call(Intrinsic::Fbm3, &[q, o, l, g]);
    let half = b.float(0.5);
    let h = b.mul(half, n);
    let a = b.add(half, h);
    b.output("f", None, a);
    b.finish().unwrap()
}

#[test]
fn filter_off_is_the_unfiltered_program() {
    let off = optimized(&fractal(0.0));
    assert_eq!(off, optimized(&plain_fractal()));
    assert!(!off.contains("dPdx") && !off.contains("dPdy"), "{off}");
    // Filtering on reads the ray differentials and folds the same way otherwise.
    let on = optimized(&fractal(1.0));
    assert!(on.contains("dPdx"), "{on}");
    // A point constant across the pixel has no footprint: nothing is built.
    let constant = network(
        r#"{"nodes": [{"name": "f", "type": "fractal",
              "inputs": {"octaves": 6, "point": [0.3, 0.2, 0.1]}}],
            "outputs": {"f": "f.outAlpha"}}"#,
    );
    let c = optimized(&constant);
    assert!(!c.contains("dPdx"), "{c}");
}

/// Shades `frags` through `backend` one fragment at a time and in batches; both as bits.
fn shade_bits(backend: &dyn Backend, p: &Program, frags: &[Fragment]) -> [Vec<u32>; 2] {
    let m = backend.compile_program(p, Duration::ZERO).unwrap();
    let env = ShadeEnv::default();
    let w = m.width();
    let mut scalar = vec![0.0f32; w * frags.len()];
    for (f, o) in frags.iter().zip(scalar.chunks_mut(w)) {
        m.shade(&ShadeCtx::new(*f, &env), o);
    }
    let mut batch = vec![0.0f32; w * frags.len()];
    shade_batch(&*m, &env, u32::MAX, frags, &mut batch);
    [scalar, batch].map(|v| v.iter().map(|x| x.to_bits()).collect())
}

#[test]
fn interpreter_and_jit_agree_bit_for_bit() {
    // Footprints from none to many cells, so lanes of one batch keep different octave
    // counts and fade different octaves.
    let frags: Vec<Fragment> = (0..67)
        .map(|i| {
            let w = [0.0, 1e-3, 0.02, 0.07, 0.2, 0.6, 3.0][i as usize % 7];
            let (dx, dy) = footprint(w);
            at(point(i), dx, dy)
        })
        .collect();
    let mut programs = vec![fractal(1.0), solid_noise(1.0)];
    programs.extend(mtlx_fractal("float"));
    programs.extend(mtlx_fractal("vector3"));
    for p in programs {
        let p = opt::run(&p, &Specialization::default()).0;
        let [a, b] = shade_bits(&InterpBackend, &p, &frags);
        assert_eq!(a, b, "interp scalar vs batch");
        let [c, d] = shade_bits(&JitBackend::default(), &p, &frags);
        assert_eq!(a, c, "interp vs jit scalar");
        assert_eq!(a, d, "interp vs jit batch");
    }
}

/// A MaterialX `fractal3d` of type `ty` (6 octaves) of the default position, its output;
/// `None` (with a printed reason) where the MaterialX libraries are not installed.
fn mtlx_fractal(ty: &str) -> Option<Program> {
    use shadenet::graph::mtlx::{self, Selection};
    let lib = match shadenet::mtlx::locate(None).and_then(|d| shadenet::mtlx::library(&d)) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("skipped: {}", shadenet::graph::error_chain(&e));
            return None;
        }
    };
    let src = format!(
        r#"<?xml version="1.0"?>
<materialx version="1.39">
<fractal3d name="n" type="{ty}"><input name="octaves" type="integer" value="6"/></fractal3d>
<output name="out" type="{ty}" nodename="n"/>
</materialx>"#
    );
    Some(
        mtlx::compile("t.mtlx", &src, lib, &Selection::default())
            .unwrap()
            .program,
    )
}

/// MaterialX's fractal filters as its image node does (always; it has no filter input),
/// with OSL's generators: fine footprints give the plain `mx_fractal3` bits, coarse ones
/// its average 0. Measured (as the `fractal` node's, on its signed output): w = 0.05:
/// 0.0048 vs 0.0086; w = 0.25: 0.0241 vs 0.0560; w = 1: 0.0716 vs 0.1900; w = 4: 0.0521 vs
/// 0.2761.
#[test]
fn materialx_fractal3d_is_filtered() {
    let Some(prog) = mtlx_fractal("float") else {
        return;
    };
    let f = |p: [f64; 3]| osl_noise::fractal3(p, 6, 2.0, 0.5);
    for (w, at_most) in [(0.05, 0.65), (0.25, 0.5), (1.0, 0.45), (4.0, 0.25)] {
        let (e, u) = errors(&prog, f, w);
        eprintln!("fractal3d w {w}: filtered {e:.4} unfiltered {u:.4}");
        assert!(e <= at_most * u, "w {w}: filtered {e} vs unfiltered {u}");
    }
    for i in 0..16 {
        let p = point(i);
        let (dx, dy) = footprint(1e-4);
        let p32 = p.map(|x| x as f32 as f64);
        assert_eq!(eval64(&prog, at(p, dx, dy)), f(p32), "{p:?}");
        let (dx, dy) = footprint(8.0);
        assert_eq!(eval64(&prog, at(p, dx, dy)), 0.0, "{p:?}");
    }
}

/// The fade band is the box's attenuation of our noise: the least-squares weight `β(w) =
/// Σ box·point / Σ point²` of `noise3` at a point against its box average over a footprint
/// of width `w` (200 points) is within 0.16 of `1 − smoothstep(0.1, 2.2, w)`. Measured β:
/// 0.995, 0.978, 0.952, 0.874, 0.771, 0.597, 0.485, 0.339, 0.176, 0.059 at w = 0.1, 0.2,
/// 0.3, 0.5, 0.7, 1, 1.2, 1.5, 2, 3 (pbrt's band drops the octave by w = 0.4, where β is
/// still 0.92).
#[test]
fn the_fade_is_the_box_attenuation_of_the_noise() {
    for w in [0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.2, 1.5, 2.0, 3.0] {
        let (dx, dy) = footprint(w);
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..200 {
            let p = point(i);
            let pt = noise::noise3(p);
            num += box_average(noise::noise3, p, dx, dy) * pt;
            den += pt * pt;
        }
        let beta = num / den;
        let t = ((w - 0.1) / 2.1f64).clamp(0.0, 1.0);
        let weight = 1.0 - t * t * (3.0 - 2.0 * t);
        assert!((beta - weight).abs() <= 0.16, "w {w}: β {beta} vs {weight}");
    }
}
