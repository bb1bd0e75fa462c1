//! The machinery of the lobe suite: one program per case, run through the JIT on many
//! (wo, wi, u) at once, and the statistics the checks use (chi-square over (cos θ, φ) bins,
//! pdf quadrature, white furnace, weight = value/pdf, reciprocity).
//!
//! **The stream trick.** Parameters (`b.param`) are compiled into a material, so changing
//! them means recompiling. The directions are fed through fragment streams instead, one
//! fragment per query: `wo = −I`, `wi = P`, `u = dPdu`, the normal is `N` and the tangent
//! `dPdv` (the tests give `N = +z`, `dPdv = +x` except in the hard cases). Streams are f32,
//! so every statistic here is of the f32 program (the JIT's, which the parity check ties
//! bit for bit to the interpreter's f32).

use crate::common::stats::chi_square;
use shadenet_graph::closure::{Closure, Frame, Lobe, LobeKind};
use shadenet_graph::ir::{Builder, Program, Stream, UnOp, Value};
use shadenet_jit::{JitBackend, JitOptions, OptLevel};
use shadenet_runtime::{Backend, Fragment, Material, ShadeEnv};
use std::f64::consts::PI;
use std::sync::Arc;
use std::time::Duration;

/// Roughness and anisotropy of one case (lobes without them ignore them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Knobs {
    /// Roughness.
    pub roughness: f64,
    /// Anisotropy (−1..1; 0 isotropic).
    pub anisotropy: f64,
}

/// Builds a lobe kind with white parameters from the knobs.
pub type MakeLobe = fn(&mut Builder, Knobs) -> LobeKind;
/// Builds a closure in `frame` seen from `wo` (world).
pub type MakeClosure = fn(&mut Builder, Frame, Value) -> Closure;

/// What a case tests: one lobe through the `Lobe` API (its own sample weight and pdf), or a
/// whole closure through the `Closure` API (mixture pdf, lobe selection).
#[derive(Clone, Copy)]
pub enum Subject {
    /// One lobe.
    Lobe(MakeLobe, Knobs),
    /// A closure.
    Closure(MakeClosure),
}

/// Where a case scatters light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sides {
    /// The viewer's hemisphere only (reciprocity applies).
    Reflect,
    /// The other hemisphere only.
    Transmit,
    /// Both (the GGX dielectric, on its own branch).
    #[allow(dead_code)]
    Both,
}

/// What the white furnace must give.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Energy {
    /// Exactly 1 (within Monte Carlo noise): a white lossless lobe.
    One,
    /// At most this (1 for every physical lobe; more for a lobe known to gain energy).
    AtMost(f64),
}

/// Deliberate faults injected into a case's program, to show that the checks fail.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mutation {
    /// Every pdf (eval and sample) times `1 + k (cos θi − ½)`: a wrong density shape.
    TiltPdf(f64),
    /// Every value and sample weight times `k`.
    ScaleValue(f64),
    /// The sample weight alone times `k`.
    ScaleWeight(f64),
    /// The eval value times `1 + k wi.x` (not reciprocal).
    Skew(f64),
}

/// One row of the table.
#[derive(Clone, Copy)]
pub struct Case {
    /// Name with its knobs.
    pub name: &'static str,
    /// Roughness / anisotropy, for messages.
    pub knobs: Option<Knobs>,
    /// What is built.
    pub subject: Subject,
    /// Where it scatters.
    pub sides: Sides,
    /// The furnace bound.
    pub energy: Energy,
    /// How far the furnace estimate may be from `albedo(wo)` (beyond 3σ).
    pub albedo_tol: f64,
    /// Whether sampling never fails, so the pdf integrates to 1.
    pub complete: bool,
    /// At the 89.9° view only: (furnace bound, albedo tolerance) replacing the others, for a
    /// lobe whose model is known to gain energy at grazing views.
    pub grazing: Option<(f64, f64)>,
    /// A peaked lobe: the pdf quadrature uses [`SUB_FINE`] points per bin side, uniform
    /// in `θ` (see `Grid`).
    pub fine: bool,
    /// Whether the chi-square is checked at the 89.9° view (false for a lobe whose density
    /// there has a spike narrower than the quadrature; the other checks still apply).
    pub chi2_grazing: bool,
    /// A fault to inject (tests of the tests only).
    pub mutation: Option<Mutation>,
}

impl Case {
    /// `name` with its knobs.
    pub fn label(&self) -> String {
        match self.knobs {
            Some(k) => format!(
                "{} (roughness {}, anisotropy {})",
                self.name, k.roughness, k.anisotropy
            ),
            None => self.name.to_string(),
        }
    }
}

/// The per-lobe properties of a table row (see [`Case`]).
#[derive(Clone, Copy)]
pub struct Props {
    /// Where it scatters.
    pub sides: Sides,
    /// The furnace bound.
    pub energy: Energy,
    /// Albedo tolerance.
    pub albedo_tol: f64,
    /// Whether sampling never fails.
    pub complete: bool,
    /// See [`Case::grazing`].
    pub grazing: Option<(f64, f64)>,
    /// See [`Case::fine`].
    pub fine: bool,
    /// See [`Case::chi2_grazing`].
    pub chi2_grazing: bool,
}

/// One table line: a lobe for every knob setting.
pub fn lobe(name: &'static str, knobs: &[Knobs], props: Props, make: MakeLobe) -> Vec<Case> {
    knobs
        .iter()
        .map(|&k| Case {
            name,
            knobs: Some(k),
            subject: Subject::Lobe(make, k),
            sides: props.sides,
            energy: props.energy,
            albedo_tol: props.albedo_tol,
            complete: props.complete,
            grazing: props.grazing,
            fine: props.fine,
            chi2_grazing: props.chi2_grazing,
            mutation: None,
        })
        .collect()
}

/// One table line: a closure.
pub fn closure(name: &'static str, props: Props, make: MakeClosure) -> Vec<Case> {
    vec![Case {
        name,
        knobs: None,
        subject: Subject::Closure(make),
        sides: props.sides,
        energy: props.energy,
        albedo_tol: props.albedo_tol,
        complete: props.complete,
        grazing: props.grazing,
        fine: props.fine,
        chi2_grazing: props.chi2_grazing,
        mutation: None,
    }]
}

/// Isotropic knobs for each roughness.
pub fn roughness(values: &[f64]) -> Vec<Knobs> {
    values
        .iter()
        .map(|&r| Knobs {
            roughness: r,
            anisotropy: 0.0,
        })
        .collect()
}

/// A white color.
pub fn white(b: &mut Builder) -> Value {
    b.color([1.0, 1.0, 1.0])
}

/// Output names, in the order [`Row`] reads them.
const OUTPUTS: [&str; 9] = [
    "value", "pdf", "rvalue", "swi", "sweight", "spdf", "svalue", "sevpdf", "albedo",
];

/// The program of a case: streams in (see the module doc), the outputs of [`Row`] out.
pub fn program(case: &Case) -> Program {
    program_with(case, true)
}

/// [`program`], with the `albedo` output black unless `with_albedo` (the statistics run
/// millions of queries and read the albedo once per view; a quadrature albedo costs more
/// than the rest of a lobe).
pub fn program_with(case: &Case, with_albedo: bool) -> Program {
    let mut b = Builder::new(case.name);
    let i = b.stream(Stream::I);
    let wo = b.unary(UnOp::Neg, i);
    let wi = b.stream(Stream::P);
    let u = b.stream(Stream::DPdu);
    let n = b.stream(Stream::N);
    let t = b.stream(Stream::DPdv);
    let frame = Frame::new(&mut b, n, t, wo);
    let mut out = match case.subject {
        Subject::Lobe(make, k) => {
            let kind = make(&mut b, k);
            let weight = white(&mut b);
            let lobe = Lobe {
                kind,
                weight,
                frame,
                component: "diffuse",
                unbuilt: None,
            };
            let e = lobe.eval(&mut b, wo, wi);
            let r = lobe.eval(&mut b, wi, wo);
            let s = lobe.sample_world(&mut b, wo, u);
            let es = lobe.eval(&mut b, wo, s.wi);
            let a = if with_albedo {
                lobe.albedo(&mut b, wo)
            } else {
                b.zero(shadenet_graph::types::Type::Color)
            };
            [
                e.value, e.pdf, r.value, s.wi, s.weight, s.pdf, es.value, es.pdf, a,
            ]
        }
        Subject::Closure(make) => {
            let c = make(&mut b, frame, wo);
            let e = c.eval(&mut b, wo, wi);
            let r = c.eval(&mut b, wi, wo);
            let s = c.sample(&mut b, wo, u);
            let es = c.eval(&mut b, wo, s.wi);
            let a = if with_albedo {
                c.albedo(&mut b, wo)
            } else {
                b.zero(shadenet_graph::types::Type::Color)
            };
            [
                e.value, e.pdf, r.value, s.wi, s.weight, s.pdf, es.value, es.pdf, a,
            ]
        }
    };
    if let Some(m) = case.mutation {
        mutate(&mut b, m, wi, &mut out);
    }
    for (name, v) in OUTPUTS.iter().zip(out) {
        b.output(name, None, v);
    }
    b.finish()
        .unwrap_or_else(|e| panic!("{}: {e}", case.label()))
}

fn mutate(b: &mut Builder, m: Mutation, wi: Value, out: &mut [Value; 9]) {
    let scale = |b: &mut Builder, v: Value, k: Value| {
        let ty = b.ty(v);
        let k = b.splat_to(ty, k);
        b.mul(v, k)
    };
    // The tilt of a density at direction `w` (world = local here: the frame is +z).
    let tilt = |b: &mut Builder, w: Value, k: f64| {
        let z = b.extract(w, 2);
        let h = b.float(0.5);
        let d = b.sub(z, h);
        let kk = b.float(k);
        let d = b.mul(kk, d);
        let one = b.float(1.0);
        b.add(one, d)
    };
    match m {
        Mutation::TiltPdf(k) => {
            let ti = tilt(b, wi, k);
            let ts = tilt(b, out[3], k);
            out[1] = scale(b, out[1], ti);
            out[5] = scale(b, out[5], ts);
            out[7] = scale(b, out[7], ts);
        }
        Mutation::ScaleValue(k) => {
            let k = b.float(k);
            for i in [0, 2, 4, 6] {
                out[i] = scale(b, out[i], k);
            }
        }
        Mutation::ScaleWeight(k) => {
            let k = b.float(k);
            out[4] = scale(b, out[4], k);
        }
        Mutation::Skew(k) => {
            let x = b.extract(wi, 0);
            let k = b.float(k);
            let x = b.mul(k, x);
            let one = b.float(1.0);
            let s = b.add(one, x);
            out[0] = scale(b, out[0], s);
        }
    }
}

/// The outputs for one fragment.
#[derive(Clone, Copy, Debug, Default)]
pub struct Row {
    /// `f |cos θi|` at (wo, wi).
    pub value: [f64; 3],
    /// pdf of wi.
    pub pdf: f64,
    /// `f |cos θo|` at (wi, wo) (swapped).
    pub rvalue: [f64; 3],
    /// The sampled direction.
    pub swi: [f64; 3],
    /// Its weight.
    pub sweight: [f64; 3],
    /// Its pdf as `sample` gives it.
    pub spdf: f64,
    /// `eval` at the sampled direction: value.
    pub svalue: [f64; 3],
    /// `eval` at the sampled direction: pdf.
    pub sevpdf: f64,
    /// `albedo(wo)`.
    pub albedo: [f64; 3],
}

/// A compiled case.
pub struct Compiled {
    /// The material.
    pub material: Arc<dyn Material>,
    /// Offsets of [`OUTPUTS`] in a fragment's floats (`usize::MAX` for a program without
    /// them, which only [`Compiled::raw`] may run).
    offsets: [usize; 9],
}

/// The JIT this suite uses (no fallback: a lobe the JIT cannot compile fails).
pub fn jit() -> JitBackend {
    JitBackend::with_options(JitOptions {
        opt: OptLevel::None,
        fallback: false,
        ..JitOptions::default()
    })
}

/// Compiles `program` with `backend`.
pub fn compile_with(backend: &dyn Backend, program: &Program) -> Compiled {
    shadenet_graph::ir::validate(program).unwrap_or_else(|e| panic!("{e}\n{program}"));
    let material = backend
        .compile_program(program, Duration::ZERO)
        .unwrap_or_else(|e| panic!("{}: {e}", program.name));
    let mut offsets = [0; 9];
    for (o, name) in offsets.iter_mut().zip(OUTPUTS) {
        *o = material
            .layout()
            .iter()
            .find(|s| s.name == name)
            .map_or(usize::MAX, |s| s.offset);
    }
    Compiled { material, offsets }
}

/// A query: view, light, uniform numbers, normal and tangent.
#[derive(Clone, Copy, Debug)]
pub struct Query {
    /// Towards the viewer.
    pub wo: [f64; 3],
    /// Towards the light.
    pub wi: [f64; 3],
    /// Uniform numbers.
    pub u: [f64; 3],
    /// Shading normal.
    pub n: [f64; 3],
    /// Tangent.
    pub t: [f64; 3],
}

impl Query {
    /// The frame this suite uses: normal +z, tangent +x.
    pub fn new(wo: [f64; 3], wi: [f64; 3], u: [f64; 3]) -> Query {
        Query {
            wo,
            wi,
            u,
            n: [0.0, 0.0, 1.0],
            t: [1.0, 0.0, 0.0],
        }
    }

    /// The fragment carrying it.
    pub fn fragment(&self) -> Fragment {
        let f = |v: [f64; 3]| v.map(|x| x as f32);
        Fragment {
            i: f(self.wo.map(|x| -x)),
            p: f(self.wi),
            dpdu: f(self.u),
            n: f(self.n),
            ng: f(self.n),
            dpdv: f(self.t),
            ..Fragment::default()
        }
    }
}

impl Compiled {
    /// Runs every query; the rows and the count of non-finite floats the guard replaced.
    pub fn run(&self, queries: &[Query]) -> (Vec<Row>, u64) {
        let frags: Vec<Fragment> = queries.iter().map(Query::fragment).collect();
        let (out, bad) = self.raw(&frags);
        let w = self.material.width();
        let rows = out.chunks(w).map(|o| self.row(o)).collect();
        (rows, bad)
    }

    /// The raw f32 outputs (fragment after fragment) and the non-finite count.
    pub fn raw(&self, frags: &[Fragment]) -> (Vec<f32>, u64) {
        let env = ShadeEnv::default();
        let mut out = vec![f32::NAN; self.material.width() * frags.len()];
        let r = shadenet_runtime::shade_many_unpacked(
            &*self.material,
            &env,
            u32::MAX,
            None,
            frags,
            &mut out,
        );
        (out, r.nonfinite)
    }

    fn row(&self, o: &[f32]) -> Row {
        let v3 = |k: usize| {
            let at = self.offsets[k];
            [o[at] as f64, o[at + 1] as f64, o[at + 2] as f64]
        };
        let s = |k: usize| o[self.offsets[k]] as f64;
        Row {
            value: v3(0),
            pdf: s(1),
            rvalue: v3(2),
            swi: v3(3),
            sweight: v3(4),
            spdf: s(5),
            svalue: v3(6),
            sevpdf: s(7),
            albedo: v3(8),
        }
    }
}

/// A small deterministic generator (SplitMix64).
pub struct Rng(pub u64);

impl Rng {
    /// A uniform number in [0, 1) with 24 random bits (exact in f32).
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 40) as f64 / (1u64 << 24) as f64
    }

    /// Three uniform numbers.
    pub fn u3(&mut self) -> [f64; 3] {
        [self.uniform(), self.uniform(), self.uniform()]
    }

    /// A uniform direction on the sphere.
    pub fn sphere(&mut self) -> [f64; 3] {
        let z = 1.0 - 2.0 * self.uniform();
        let phi = 2.0 * PI * self.uniform();
        let r = (1.0 - z * z).max(0.0).sqrt();
        [r * phi.cos(), r * phi.sin(), z]
    }
}

/// The direction at polar angle `theta_deg` from +z, azimuth 0.3 rad (off the tangent, so
/// anisotropy shows).
pub fn view(theta_deg: f64) -> [f64; 3] {
    let (t, p) = (theta_deg.to_radians(), 0.3f64);
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

/// The direction with `cos θ = z` and azimuth `phi`.
pub fn dir(z: f64, phi: f64) -> [f64; 3] {
    let r = (1.0 - z * z).max(0.0).sqrt();
    [r * phi.cos(), r * phi.sin(), z]
}

/// The grazing view, where [`Case::grazing`] applies.
pub const GRAZING: f64 = 89.9;

/// Bins of the chi-square test: `cos θ` over [−1, 1] and `φ` over [0, 2π).
pub const BINS_Z: usize = 20;
/// φ bins.
pub const BINS_PHI: usize = 20;
/// Quadrature points per bin side.
pub const SUB: usize = 6;
/// Quadrature points per bin side for a [`Case::fine`] case.
pub const SUB_FINE: usize = 40;
/// Samples per (case, view).
pub const SAMPLES: usize = 100_000;

/// The quadrature points of the pdf: `sub` per bin side, the `z` points of every bin in
/// order with their weights (`dz` of their cell), and the `φ` points.
struct Grid {
    sub: usize,
    zs: Vec<(f64, f64)>,
    phis: usize,
}

impl Grid {
    /// [`SUB`] midpoints per side uniform in `z`, or for a peaked (`fine`) lobe
    /// [`SUB_FINE`] uniform in `θ` within each `z` bin (weight `sin θ dθ`), which resolve
    /// a lobe a few hundredths of a radian wide at the pole as well as at the horizon.
    fn new(fine: bool) -> Grid {
        let sub = if fine { SUB_FINE } else { SUB };
        let mut zs = Vec::with_capacity(BINS_Z * sub);
        for iz in 0..BINS_Z {
            let z0 = -1.0 + iz as f64 * 2.0 / BINS_Z as f64;
            let z1 = z0 + 2.0 / BINS_Z as f64;
            for k in 0..sub {
                if fine {
                    let (t1, t0) = (z0.clamp(-1.0, 1.0).acos(), z1.clamp(-1.0, 1.0).acos());
                    let dt = (t1 - t0) / sub as f64;
                    let t = t0 + (k as f64 + 0.5) * dt;
                    zs.push((t.cos(), t.sin() * dt));
                } else {
                    let dz = (z1 - z0) / sub as f64;
                    zs.push((z0 + (k as f64 + 0.5) * dz, dz));
                }
            }
        }
        Grid {
            sub,
            zs,
            phis: BINS_PHI * sub,
        }
    }
}

/// Everything measured for one case and one view angle.
#[derive(Clone, Debug)]
pub struct Measured {
    /// View angle (degrees).
    pub theta: f64,
    /// Chi-square statistic, degrees of freedom, p-value; `Err` for samples where the pdf
    /// is 0 or a sample with a bad direction.
    pub chi2: Result<(f64, usize, f64), String>,
    /// ∫ pdf dω by quadrature.
    pub pdf_integral: f64,
    /// Mean sample weight (channel 0) and its standard error.
    pub furnace: (f64, f64),
    /// `albedo(wo)` (channel 0).
    pub albedo: f64,
    /// Worst relative error of `weight` against `value/pdf` at the sampled direction, and of
    /// the sample's pdf against eval's.
    pub weight_err: f64,
    /// Worst relative error of the sample pdf against eval's.
    pub pdf_err: f64,
    /// Worst reciprocity error (relative), reflection cases only.
    pub recip_err: f64,
    /// Non-finite floats the guard caught.
    pub nonfinite: u64,
}

/// The view angles every case is measured at.
pub const VIEWS: [f64; 4] = [0.0, 45.0, 80.0, GRAZING];

/// Measures `case` at every view.
pub fn measure(case: &Case) -> Vec<Measured> {
    let c = compile_with(&jit(), &program_with(case, false));
    let full = compile_with(&jit(), &program(case));
    VIEWS
        .iter()
        .enumerate()
        .map(|(k, &theta)| {
            let mut m = measure_view(case, &c, theta, seed(case) + k as u64);
            let q = Query::new(view(theta), [0.0, 0.0, 1.0], [0.5; 3]);
            let (rows, bad) = full.run(&[q]);
            m.albedo = rows[0].albedo[0];
            m.nonfinite += bad;
            m
        })
        .collect()
}

/// A seed of its own for every case (FNV-1a of its label), so that lobes sampled the same
/// way do not see the same numbers.
fn seed(case: &Case) -> u64 {
    case.label().bytes().fold(0xCBF2_9CE4_8422_2325, |h, c| {
        (h ^ c as u64).wrapping_mul(0x100_0000_01B3)
    })
}

fn measure_view(case: &Case, c: &Compiled, theta: f64, seed: u64) -> Measured {
    let wo = view(theta);
    let mut rng = Rng(seed);
    // Quadrature of the pdf over every bin.
    let grid = Grid::new(case.fine);
    let mut qs = Vec::with_capacity(grid.zs.len() * grid.phis);
    for &(z, _) in &grid.zs {
        for ip in 0..grid.phis {
            let phi = (ip as f64 + 0.5) * 2.0 * PI / grid.phis as f64;
            qs.push(Query::new(wo, dir(z, phi), [0.5; 3]));
        }
    }
    let (rows, bad_q) = c.run(&qs);
    let dphi = 2.0 * PI / grid.phis as f64;
    let mut expected = vec![0.0; BINS_Z * BINS_PHI];
    for (k, r) in rows.iter().enumerate() {
        let (iz, ip) = (k / grid.phis / grid.sub, k % grid.phis / grid.sub);
        expected[iz * BINS_PHI + ip] += r.pdf * grid.zs[k / grid.phis].1 * dphi;
    }
    let pdf_integral: f64 = expected.iter().sum();
    // Reciprocity on the quadrature points of the viewer's side.
    let mut recip_err: f64 = 0.0;
    if case.sides == Sides::Reflect {
        for (q, r) in qs.iter().zip(&rows) {
            if q.wi[2] < 0.02 || wo[2] < 0.02 {
                continue;
            }
            for ch in 0..3 {
                let a = r.value[ch] / q.wi[2];
                let bb = r.rvalue[ch] / wo[2];
                let e = (a - bb).abs() / (a.abs().max(bb.abs()) + 1e-6);
                recip_err = recip_err.max(e);
            }
        }
    }
    // Samples.
    let ss: Vec<Query> = (0..SAMPLES)
        .map(|_| Query::new(wo, [0.0, 0.0, 1.0], rng.u3()))
        .collect();
    let (rows, bad_s) = c.run(&ss);
    let mut observed = vec![0.0; BINS_Z * BINS_PHI];
    let mut failed = 0.0;
    let mut chi_err = None;
    let (mut sum, mut sum2) = (0.0, 0.0);
    let (mut weight_err, mut pdf_err): (f64, f64) = (0.0, 0.0);
    for r in &rows {
        let w = r.sweight[0];
        sum += w;
        sum2 += w * w;
        if r.spdf <= 0.0 {
            failed += 1.0;
            if r.sweight.iter().any(|&x| x != 0.0) {
                chi_err.get_or_insert(format!("weight {:?} where pdf = 0", r.sweight));
            }
            continue;
        }
        let len = r.swi.iter().map(|x| x * x).sum::<f64>().sqrt();
        if (len - 1.0).abs() > 1e-3 {
            chi_err.get_or_insert(format!("sampled direction {:?} not unit", r.swi));
            continue;
        }
        let z = r.swi[2].clamp(-1.0, 1.0);
        let phi = r.swi[1].atan2(r.swi[0]).rem_euclid(2.0 * PI);
        let iz = (((z + 1.0) / 2.0 * BINS_Z as f64) as usize).min(BINS_Z - 1);
        let ip = ((phi / (2.0 * PI) * BINS_PHI as f64) as usize).min(BINS_PHI - 1);
        observed[iz * BINS_PHI + ip] += 1.0;
        pdf_err = pdf_err.max((r.spdf - r.sevpdf).abs() / r.spdf.max(r.sevpdf));
        if r.sevpdf > 0.0 {
            for ch in 0..3 {
                let want = r.svalue[ch] / r.sevpdf;
                let e = (r.sweight[ch] - want).abs() / (want.abs().max(1e-3));
                weight_err = weight_err.max(e);
            }
        }
    }
    let n = SAMPLES as f64;
    let mean = sum / n;
    let var = (sum2 / n - mean * mean).max(0.0);
    let mut exp: Vec<f64> = expected.iter().map(|e| e * n).collect();
    exp.push(((1.0 - pdf_integral) * n).max(0.0));
    observed.push(failed);
    let chi2 = match chi_err {
        Some(e) => Err(e),
        None => chi_square(&observed, &exp),
    };
    Measured {
        theta,
        chi2,
        pdf_integral,
        furnace: (mean, (var / n).sqrt()),
        albedo: 0.0,
        weight_err,
        pdf_err,
        recip_err,
        nonfinite: bad_q + bad_s,
    }
}
