//! The parity suite: every back end against the interpreter (DESIGN §6).
//!
//! One table of back ends ([`backends`]) runs through everything here: a table of every IR
//! op on every type it is defined on ([`every_op_on_every_type`], generated from the op
//! typing rules, so a new op joins by itself) over ordinary and hard inputs (0, -0,
//! denormals, ±inf, NaN, huge, tiny, grazing vectors, integer extremes), the regions and
//! scene intrinsics, every example network under several specializations, and random
//! programs ([`random_programs`]; the property generator of the other branch plugs into
//! [`check_program`]). A new back end joins the whole suite with one line in [`backends`].
//!
//! Parity is checked on the output floats, on the non-finite counts and on the loops stopped
//! at the iteration limit (`Material::loop_limits`; the loop rows run on the CPU back ends
//! only: the GPU runs them but does not count stops; its loop rows are in
//! `gpu/tests/backend.rs`). Every row has a
//! [`Class`]: exact arithmetic (`+ - * /`, sqrt, comparisons, selects, min/max,
//! floor/fract, …), intrinsics (noise, colour conversions, textures, light samples), one
//! transcendental op, or transcendentals mixed with other ops; a back end states its
//! [`Tolerance`] per class. The JIT calls the interpreter's own Rust functions for
//! transcendentals and intrinsics, so it is bit-identical everywhere.
//!
//! # The GPU
//!
//! The GPU back end (`shadenet_gpu`, on the shared device; every test prints `SKIPPED: …`
//! and leaves it out where there is no adapter, and fails instead with
//! `SHADENET_REQUIRE_GPU=1`) shades through [`Material::shade_many`] ([`Drive::Many`]), with
//! no fallback to the interpreter (a program it cannot compile fails the suite, and every
//! call must have dispatched GPU passes). Its [`Tolerance::Gpu`]:
//!
//! - exact and intrinsic rows: bit for bit, non-finite counts included (the WGSL library
//!   ports every op, noise, fBm, cell noise, HSV and texture lookups operation for
//!   operation; light samples, traces and occlusion are host steps running the CPU's code);
//! - rows of one transcendental op: the bound `shadenet_gpu::testing::documented_bound`
//!   gives for the op's arguments (the table in `shadenet_gpu::emit`: 1–4 ulps; sin, cos and
//!   tan beyond |x| = 10⁴ only finite where the CPU is finite);
//! - rows mixing transcendentals with other ops: [`MIXED_ULPS`] ulps or [`MIXED_ABS`]
//!   absolute, and at most [`MIXED_OUTLIERS`] of the outputs beyond that (a 1-ulp
//!   difference before a comparison, `floor` or a noise lattice can move an output by a
//!   whole step).
//!
//! The random programs run on the GPU for every fourth seed only (a GPU compile costs a
//! pipeline per pass); [`gpu_pass_plans_agree`] checks that the pass partitioning (one fused
//! kernel, or 2, 3, 5 or 8 passes) changes no bit.
//!
//! Exceptions the GPU cannot match (none of them is skipped silently: each is a bound
//! above):
//! - `sin`, `cos`, `tan` of |x| > 10⁴ (the device's argument reduction): finite where the
//!   CPU is finite, nothing more;
//! - rows mixing transcendentals with branches, `floor` or noise: the few outputs a
//!   1-ulp difference moves across a step ([`MIXED_OUTLIERS`]);
//! - "if nested" (`sin` of P.x): fragments with |P.x| > 10⁴ are not compared
//!   ([`Class::MixedExcept`]).
//!
//! All of the above is the bit-exact contract of a software rasterizer (CI's lavapipe). On
//! a hardware GPU (or anywhere under `SHADENET_GPU_ACCURACY=hardware`) the GPU is held to
//! [`Tolerance::GpuHardware`] instead, the contract of `shadenet_gpu::testing::hardware`
//! (subnormals may be flushed, `sqrt` and division a few ulps off, `a * b + c` fused):
//! one-op rows value by value within the op's hardware bound; every other row, and every
//! pass plan against the fused one, by `hardware::check_outputs` (fragments with subnormal,
//! non-finite or huge inputs not compared; at most 5% of the others' outputs beyond 64 ulps and
//! 1e-5 relative).

use shadenet_gpu::testing::{
    Transcendental, accuracy, device_or_skip, documented_bound, hardware, same, within,
};
use shadenet_gpu::{GpuBackend, GpuOptions, PassMode};
use shadenet_graph::ir::{BinOp, Intrinsic, Program, Space, UnOp, XformKind, parse};
use shadenet_graph::lower::{Literal, lower_single};
use shadenet_graph::nodes::{LightDesc, LightKind, NodeLibrary};
use shadenet_graph::ops;
use shadenet_graph::opt::{self, Passes, Specialization};
use shadenet_graph::types::{ConstValue, Type};
use shadenet_jit::{JitBackend, JitOptions, OptLevel};
use shadenet_runtime::testing::{HARD_FLOATS, HARD_INTS, HashScene};
use shadenet_runtime::{
    Backend, Fragment, InterpBackend, Material, MaterialCache, SceneServices, ShadeCtx, ShadeEnv,
    shade_batch, shade_many_unpacked,
};
use std::sync::Arc;
use std::time::Duration;

/// How a back end is driven: one fragment per call, four-wide packets, or a whole batch
/// through [`Material::shade_many`] (the GPU's entry).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Drive {
    Scalar,
    Batch,
    Many,
}

/// What a back end promises against the interpreter, per [`Class`] of row.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Tolerance {
    /// At most `exact` ulps on exact rows and `other` on every other row (with a 0 bound,
    /// equal non-finite counts too).
    Ulps { exact: u32, other: u32 },
    /// The GPU's documented accuracy (see the module documentation).
    Gpu,
    /// The GPU's hardware contract (`shadenet_gpu::testing::hardware`): on a hardware GPU,
    /// or anywhere under `SHADENET_GPU_ACCURACY=hardware` (see the module documentation).
    GpuHardware,
}

/// The JIT calls the interpreter's Rust functions for transcendentals: bit-identical.
const BIT_IDENTICAL: Tolerance = Tolerance::Ulps { exact: 0, other: 0 };

/// GPU, rows mixing transcendentals with other ops: the ulps, or the absolute difference,
/// an output may show...
const MIXED_ULPS: u64 = 64;
/// ... (absolute, for outputs near zero, where a few ulps of an input are many of the
/// output) ...
const MIXED_ABS: f32 = 1e-5;
/// ... and the share of outputs allowed beyond both (moved across a step by a 1-ulp
/// difference before a comparison, `floor` or a noise lattice).
const MIXED_OUTLIERS: f64 = 0.01;

struct UnderTest {
    name: &'static str,
    backend: Box<dyn Backend>,
    drive: Drive,
    tolerance: Tolerance,
    /// Random programs: only seeds that are multiples of this.
    random_every: u64,
}

fn jit(opt: OptLevel) -> JitBackend {
    // No silent fallback: an op the JIT cannot compile fails the suite.
    JitBackend::with_options(JitOptions {
        opt,
        fallback: false,
        ..JitOptions::default()
    })
}

/// Whether the shared device is held to the hardware contract
/// ([`shadenet_gpu::Accuracy::Hardware`]) instead of the bit-exact one.
fn hardware_contract() -> bool {
    shadenet_gpu::GpuContext::shared()
        .is_ok_and(|c| accuracy(&c) == shadenet_gpu::Accuracy::Hardware)
}

/// The GPU back end on the shared device, without fallback; `None` (after `SKIPPED: …` on
/// stderr, once per test binary) without an adapter.
fn gpu() -> Option<GpuBackend> {
    static DEVICE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *DEVICE.get_or_init(|| device_or_skip("the parity suite's GPU back end").is_some());
    ok.then(|| {
        GpuBackend::new(GpuOptions::default(), Arc::new(InterpBackend))
            .expect("the device device_or_skip opened")
            .without_fallback()
    })
}

/// Every back end under test. A new back end joins the whole suite with one line here.
fn backends() -> Vec<UnderTest> {
    let ut = |name, backend: JitBackend, drive| UnderTest {
        name,
        backend: Box::new(backend),
        drive,
        tolerance: BIT_IDENTICAL,
        random_every: 1,
    };
    let mut v = vec![
        ut("jit-scalar", jit(OptLevel::None), Drive::Scalar),
        ut("jit-batch", jit(OptLevel::None), Drive::Batch),
        ut("jit-scalar-opt", jit(OptLevel::Speed), Drive::Scalar),
        ut("jit-batch-opt", jit(OptLevel::Speed), Drive::Batch),
        // The batch entry walking every packet of a call (`Material::shade_many`).
        ut("jit-many", jit(OptLevel::Speed), Drive::Many),
    ];
    if let Some(gpu) = gpu() {
        let hardware = hardware_contract();
        v.push(UnderTest {
            name: "gpu",
            backend: Box::new(gpu),
            drive: Drive::Many,
            tolerance: if hardware {
                Tolerance::GpuHardware
            } else {
                Tolerance::Gpu
            },
            random_every: 4,
        });
    }
    v
}

/// The class of a row: which part of a back end's [`Tolerance`] applies.
#[derive(Clone, Debug)]
enum Class {
    /// Exact IEEE arithmetic, comparisons, selects, rounding ops, control flow.
    Exact,
    /// Noise, fBm, cell noise, colour conversions, textures, light samples.
    Intrinsic,
    /// One transcendental op; `args` outputs its operands (the first, then the second) so
    /// that the bound of their domain applies.
    Op {
        op: Transcendental,
        args: Box<Program>,
    },
    /// Transcendentals mixed with other ops.
    Mixed,
    /// [`Class::Mixed`], except on the fragments `excused` accepts, where an op's argument is
    /// outside the domain of the GPU's bound (`why`): there, nothing is compared.
    MixedExcept {
        why: &'static str,
        excused: fn(&Fragment) -> bool,
    },
}

impl Class {
    fn is_exact(&self) -> bool {
        matches!(self, Class::Exact)
    }
}

/// Shades every fragment; returns the outputs (fragment after fragment) and the non-finite
/// count.
fn shade_all(
    m: &dyn Material,
    drive: Drive,
    env: &ShadeEnv,
    mask: u32,
    frags: &[Fragment],
) -> (Vec<f32>, u64) {
    let w = m.width();
    let mut out = vec![f32::NAN; w * frags.len()];
    match drive {
        Drive::Scalar => {
            let mut bad = 0;
            for (f, o) in frags.iter().zip(out.chunks_mut(w)) {
                let ctx = ShadeCtx {
                    frag: *f,
                    env,
                    mask,
                    scene: None,
                };
                bad += m.shade(&ctx, o) as u64;
            }
            (out, bad)
        }
        Drive::Batch => {
            let bad = shade_batch(m, env, mask, frags, &mut out);
            (out, bad)
        }
        Drive::Many => {
            let r = shade_many_unpacked(m, env, mask, None, frags, &mut out);
            ran_on_the_device(m, &r);
            (out, r.nonfinite)
        }
    }
}

/// A GPU material must have shaded on the device: passes dispatched (a device error makes it
/// shade on its companion back end instead, which would hide everything this suite checks).
fn ran_on_the_device(m: &dyn Material, r: &shadenet_runtime::BatchResult) {
    if m.info().backend == "gpu" {
        assert!(
            r.times.passes > 0,
            "the GPU material shaded without dispatching a pass (a device error?)"
        );
    }
}

use shadenet_gpu::testing::ulps;

/// Compiles `program` as it is with every back end and checks each against the
/// interpreter on `frags`. Panics with the first difference.
fn check_program(
    what: &str,
    program: &Program,
    env: &ShadeEnv,
    mask: u32,
    frags: &[Fragment],
    class: Class,
) {
    check_program_on(what, program, env, mask, frags, class, &|_| true)
}

/// [`check_program`] on the back ends `include` accepts.
fn check_program_on(
    what: &str,
    program: &Program,
    env: &ShadeEnv,
    mask: u32,
    frags: &[Fragment],
    class: Class,
    include: &dyn Fn(&UnderTest) -> bool,
) {
    shadenet_graph::ir::validate(program).unwrap_or_else(|e| panic!("{what}: {e}\n{program}"));
    let reference = InterpBackend
        .compile_program(program, Duration::ZERO)
        .unwrap_or_else(|e| panic!("{what}: interp: {e}"));
    let (want, want_bad) = shade_all(&*reference, Drive::Scalar, env, mask, frags);
    // The operands of a one-op row, per fragment.
    let args = match &class {
        Class::Op { args, .. } => {
            let m = InterpBackend
                .compile_program(args, Duration::ZERO)
                .unwrap_or_else(|e| panic!("{what}: args: {e}"));
            Some((shade_all(&*m, Drive::Scalar, env, mask, frags).0, m.width()))
        }
        _ => None,
    };
    for ut in backends().into_iter().filter(|ut| include(ut)) {
        let m = ut
            .backend
            .compile_program(program, Duration::ZERO)
            .unwrap_or_else(|e| panic!("{what}: {}: {e}\n{program}", ut.name));
        assert_eq!(
            m.layout(),
            reference.layout(),
            "{what}: {}: layout",
            ut.name
        );
        let (got, got_bad) = shade_all(&*m, ut.drive, env, mask, frags);
        // Loops stopped at the iteration limit: counted alike (a fresh material per back
        // end, so its total is this call's).
        assert_eq!(
            m.loop_limits(),
            reference.loop_limits(),
            "{what}: {}: loops stopped at the iteration limit\n{program}",
            ut.name
        );
        let seen = Seen {
            what,
            program,
            frags,
            width: m.width().max(1),
            got: (&got, got_bad),
            want: (&want, want_bad),
        };
        verify(&ut, &class, &seen, args.as_ref());
    }
}

/// One back end's outputs against the interpreter's, for [`verify`].
struct Seen<'a> {
    what: &'a str,
    program: &'a Program,
    frags: &'a [Fragment],
    width: usize,
    /// Outputs and non-finite count of the back end under test.
    got: (&'a [f32], u64),
    /// The interpreter's.
    want: (&'a [f32], u64),
}

/// Checks `seen` against the back end's tolerance for `class` (`args`: the operands of a
/// [`Class::Op`] row, per fragment, and their width). Panics with the first difference.
fn verify(ut: &UnderTest, class: &Class, seen: &Seen, args: Option<&(Vec<f32>, usize)>) {
    if ut.tolerance == Tolerance::GpuHardware {
        return verify_hardware(ut, class, seen, args);
    }
    let Seen {
        what,
        program,
        frags,
        width: w,
        got: (got, got_bad),
        want: (want, want_bad),
    } = *seen;
    {
        let differs = |i: usize, why: String| -> String {
            let f = &frags[i / w];
            format!(
                "{what}: {} differs from the interpreter at fragment {} output float {}: \
                 got {:?} ({:#010x}), want {:?} ({:#010x}): {why}\nfragment: {f:?}\n{program}",
                ut.name,
                i / w,
                i % w,
                got[i],
                got[i].to_bits(),
                want[i],
                want[i].to_bits()
            )
        };
        let counts_must_match = match ut.tolerance {
            Tolerance::Ulps { exact, other } => {
                let bound = if class.is_exact() { exact } else { other } as u64;
                for (i, (g, x)) in got.iter().zip(want).enumerate() {
                    let d = ulps(*g, *x);
                    if d > bound {
                        panic!("{}", differs(i, format!("{d} ulps > {bound}")));
                    }
                }
                bound == 0
            }
            Tolerance::GpuHardware => unreachable!("verify_hardware checks it"),
            Tolerance::Gpu => match class {
                Class::Exact | Class::Intrinsic => {
                    for (i, (g, x)) in got.iter().zip(want).enumerate() {
                        if g.to_bits() != x.to_bits() {
                            panic!("{}", differs(i, "not bit-identical".into()));
                        }
                    }
                    true
                }
                Class::Op { op, .. } => {
                    let (args, aw) = args.expect("operands");
                    for (i, (g, x)) in got.iter().zip(want).enumerate() {
                        let (f, c) = (i / w, i % w);
                        let a = &args[f * aw..(f + 1) * aw];
                        let (ax, ay) = (a[c], a.get(w + c).copied().unwrap_or(0.0));
                        // The CPU's value before the output guard (0 where it was not
                        // finite): the bound's domain depends on it.
                        let raw = raw_result(*op, ax, ay);
                        let (domain, bound) = documented_bound(*op, ax, ay, raw);
                        let guarded_away = !raw.is_finite() && *g == 0.0;
                        if !(within(bound, ax, *g, *x) || guarded_away) {
                            panic!(
                                "{}",
                                differs(
                                    i,
                                    format!(
                                        "operands ({ax:?}, {ay:?}): {domain}: outside {bound:?}"
                                    )
                                )
                            );
                        }
                    }
                    false
                }
                Class::Mixed | Class::MixedExcept { .. } => {
                    let excused = |i: usize| match class {
                        Class::MixedExcept { excused, .. } => excused(&frags[i / w]),
                        _ => false,
                    };
                    let mut outliers = Vec::new();
                    for (i, (g, x)) in got.iter().zip(want).enumerate() {
                        if !(same(*g, *x)
                            || ulps(*g, *x) <= MIXED_ULPS
                            || (g - x).abs() <= MIXED_ABS
                            || excused(i))
                        {
                            outliers.push(i);
                        }
                    }
                    let share = outliers.len() as f64 / got.len().max(1) as f64;
                    if std::env::var("SHADENET_PARITY_REPORT").is_ok() {
                        let differ = got
                            .iter()
                            .zip(want)
                            .filter(|(g, x)| !same(**g, **x))
                            .count();
                        let worst = got.iter().zip(want).map(|(g, x)| ulps(*g, *x)).max();
                        let exempt = match class {
                            Class::MixedExcept { why, .. } => format!(
                                ", {} not compared ({why})",
                                (0..got.len()).filter(|&i| excused(i)).count()
                            ),
                            _ => String::new(),
                        };
                        eprintln!(
                            "{what}: {}: {differ} of {} outputs differ, worst {worst:?} ulps, {} \
                             beyond the bound{exempt}",
                            ut.name,
                            got.len(),
                            outliers.len()
                        );
                    }
                    if share > MIXED_OUTLIERS {
                        panic!(
                            "{}",
                            differs(
                                outliers[0],
                                format!(
                                    "{} of {} outputs ({:.2}%) beyond {MIXED_ULPS} ulps and \
                                     {MIXED_ABS} absolute (at most {}% may be)",
                                    outliers.len(),
                                    got.len(),
                                    100.0 * share,
                                    100.0 * MIXED_OUTLIERS
                                )
                            )
                        );
                    }
                    false
                }
            },
        };
        if counts_must_match {
            assert_eq!(got_bad, want_bad, "{what}: {}: non-finite count", ut.name);
        }
    }
}

/// [`verify`] under [`Tolerance::GpuHardware`]: a one-op row value by value (free where an
/// operand is infinite, NaN or huge, or the CPU's result is not finite; otherwise the
/// hardware bound of the op against the CPU's result for the operands as they are or
/// flushed); every other row by `hardware::check_outputs` on the fragments in its domain
/// (and not excused by [`Class::MixedExcept`]).
fn verify_hardware(ut: &UnderTest, class: &Class, seen: &Seen, args: Option<&(Vec<f32>, usize)>) {
    let Seen {
        what,
        program,
        frags,
        width: w,
        got: (got, _),
        want: (want, _),
    } = *seen;
    let streams = hardware::streams_read(program);
    if let Class::Op { op, .. } = class {
        let (args, aw) = args.expect("operands");
        for (i, g) in got.iter().enumerate() {
            let (f, c) = (i / w, i % w);
            let a = &args[f * aw..(f + 1) * aw];
            let (ax, ay) = (a[c], a.get(w + c).copied().unwrap_or(0.0));
            // The operands as the args program outputs them are guarded (a non-finite one
            // reads 0): a fragment with a free input is left out as a whole.
            if hardware::free_operand(ax)
                || hardware::free_operand(ay)
                || hardware::fragment_free(&frags[f], &streams)
            {
                continue;
            }
            let ok = hardware::ftz_equal(*g, want[i])
                || hardware::ftz_variants(&[ax, ay]).iter().any(|v| {
                    let raw = raw_result(*op, v[0], v[1]);
                    let (_, bound) = hardware::transcendental_bound(*op, v[0], v[1], raw);
                    !raw.is_finite() || hardware::within(bound, v[0], *g, raw)
                });
            assert!(
                ok,
                "{what}: {} (hardware contract) differs from the interpreter at fragment {f} \
                 output float {c}: operands ({ax:?}, {ay:?}): got {g:?}, want {:?}\n{program}",
                ut.name, want[i]
            );
        }
        return;
    }
    let compared = |f: usize| {
        hardware::fragment_in_domain(&frags[f], &streams)
            && !matches!(class, Class::MixedExcept { excused, .. } if excused(&frags[f]))
    };
    match hardware::check_outputs(got, want, w, &compared) {
        Ok(r) => {
            if std::env::var("SHADENET_PARITY_REPORT").is_ok() {
                eprintln!("{what}: {} (hardware contract): {r}", ut.name);
            }
        }
        Err(e) => panic!(
            "{what}: {} (hardware contract) differs from the interpreter: {e}\n{program}",
            ut.name
        ),
    }
}

/// The CPU's result of a transcendental op on one component (`ops`, in f32).
fn raw_result(op: Transcendental, x: f32, y: f32) -> f32 {
    use shadenet_graph::ops::Val;
    let un = |u| ops::unary(u, Val::Float(x)).as_float();
    match op {
        Transcendental::Exp => un(UnOp::Exp),
        Transcendental::Log => un(UnOp::Log),
        Transcendental::Sin => un(UnOp::Sin),
        Transcendental::Cos => un(UnOp::Cos),
        Transcendental::Tan => un(UnOp::Tan),
        Transcendental::Asin => un(UnOp::Asin),
        Transcendental::Acos => un(UnOp::Acos),
        Transcendental::Atan2 => ops::binary(BinOp::Atan2, Val::Float(x), Val::Float(y)).as_float(),
        Transcendental::Pow => ops::pow(x, y),
    }
}

// ---- inputs ----

const HARD: &[f32] = HARD_FLOATS;
const INTS: &[i32] = HARD_INTS;

/// Fragments covering every pair of hard floats in (P.x, P.y), every pair of ints in
/// (raydepth, raytype), hard vectors in P, N, I, uv, and a few grazing configurations; the
/// count is not a multiple of 4, so the batch entry's padding is exercised.
fn hard_fragments() -> Vec<Fragment> {
    let h = HARD;
    let n = h.len();
    let mut v = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let k = |o: usize| h[(i * 7 + j * 3 + o) % n];
            v.push(Fragment {
                p: [h[i], h[j], k(1)],
                n: [h[j], k(2), h[i]],
                ng: [k(3), h[i], h[j]],
                i: [k(4), h[j], h[i]],
                uv: [h[i], h[j]],
                dpdu: [k(5), k(6), k(7)],
                dpdv: [h[j], h[i], k(8)],
                dpdx: [k(9), h[j], k(10)],
                dpdy: [h[i], k(11), k(12)],
                time: k(13),
                ray_type: INTS[j % INTS.len()],
                ray_depth: INTS[i % INTS.len()],
                seed: (i * n + j) as u32,
                rand: [h[i], h[j], k(14), k(15)],
            });
        }
    }
    // Grazing: N almost perpendicular to I and to the light directions.
    for (pp, nn, ii) in [
        ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, -1e-7]),
        ([0.3, -0.2, 0.0], [1e-7, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([1.0, 1.0, 2.0], [0.0, 1.0, 1e-30], [0.0, -1.0, 1e-38]),
    ] {
        v.push(Fragment {
            p: pp,
            n: nn,
            ng: nn,
            i: ii,
            uv: [0.5, 0.25],
            ray_type: 1,
            ..Fragment::default()
        });
    }
    assert_ne!(v.len() % 4, 0);
    v
}

/// The parity environment (`runtime::testing::parity_env`): point, ambient, distant, spot,
/// quad and environment lights, a camera and an object transform.
fn env() -> ShadeEnv {
    shadenet_runtime::testing::parity_env()
}

/// The inputs every op row reads, as IR text: two values of each type, all varying.
const INPUTS: &str = "
  %p = stream P : vec3
  %n = stream N : vec3
  %a = extract %p, 0 : float
  %b = extract %p, 1 : float
  %c = extract %p, 2 : float
  %uv = stream uv : vec2
  %ba = construct %b, %a : vec2
  %pc = construct %a, %b, %c : color
  %nx = extract %n, 0 : float
  %ny = extract %n, 1 : float
  %nz = extract %n, 2 : float
  %nc = construct %nx, %ny, %nz : color
  %p4 = construct %a, %b, %c, %nx : vec4
  %n4 = construct %nx, %ny, %nz, %b : vec4
  %pc4 = construct %a, %b, %c, %nz : color4
  %nc4 = construct %nx, %ny, %nz, %a : color4
  %k = stream raydepth : int
  %m = stream raytype : int
  %q = lt %a, %b : bool
  %r = gt %k, %m : bool
";

/// The two inputs of a type, by label.
fn inputs(ty: Type) -> Option<(&'static str, &'static str)> {
    Some(match ty {
        Type::Float => ("%a", "%b"),
        Type::Vec2 => ("%uv", "%ba"),
        Type::Vec3 => ("%p", "%n"),
        Type::Color => ("%pc", "%nc"),
        Type::Vec4 => ("%p4", "%n4"),
        Type::Color4 => ("%pc4", "%nc4"),
        Type::Int => ("%k", "%m"),
        Type::Bool => ("%q", "%r"),
        Type::Matrix33 | Type::Matrix44 | Type::String | Type::Closure(_) => return None,
    })
}

const TYPES: [Type; 8] = [
    Type::Float,
    Type::Vec2,
    Type::Vec3,
    Type::Color,
    Type::Vec4,
    Type::Color4,
    Type::Int,
    Type::Bool,
];

fn program(body: &str) -> Program {
    let text = format!("program \"row\" {{\n{INPUTS}\n{body}\n  output r %x\n}}\n");
    parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// A program that outputs the given operands (for [`Class::Op`]).
fn operands(labels: &[&str]) -> Program {
    let outputs: Vec<String> = labels
        .iter()
        .enumerate()
        .map(|(k, l)| format!("  output o{k} {l}\n"))
        .collect();
    let text = format!(
        "program \"operands\" {{\n{INPUTS}\n{}}}\n",
        outputs.concat()
    );
    parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// One row of the op table: a name, the program, its class.
type Row = (String, Program, Class);

/// Every unary and binary op on every type it is defined on, every conversion, select,
/// construct/extract/splat, every intrinsic, every transform, matrix products.
fn op_table() -> Vec<Row> {
    let mut rows: Vec<Row> = Vec::new();
    for &op in UnOp::ALL {
        for ty in TYPES {
            if let Some(rt) = ops::unary_type(op, ty) {
                let (x, _) = inputs(ty).unwrap();
                let body = format!("  %x = {} {x} : {}", op.name(), rt.name());
                let class = match Transcendental::of_unary(op) {
                    Some(op) => Class::Op {
                        op,
                        args: Box::new(operands(&[x])),
                    },
                    None => Class::Exact,
                };
                rows.push((
                    format!("{} {}", op.name(), ty.name()),
                    program(&body),
                    class,
                ));
            }
        }
    }
    for &op in BinOp::ALL {
        for ty in TYPES {
            if let Some(rt) = ops::binary_type(op, ty, ty) {
                let (x, y) = inputs(ty).unwrap();
                // Both operand orders, and each operand against itself.
                for (u, v) in [(x, y), (y, x), (x, x)] {
                    let class = match Transcendental::of_binary(op) {
                        Some(op) => Class::Op {
                            op,
                            args: Box::new(operands(&[u, v])),
                        },
                        None => Class::Exact,
                    };
                    let body = format!("  %x = {} {u}, {v} : {}", op.name(), rt.name());
                    rows.push((
                        format!("{} {} ({u}, {v})", op.name(), ty.name()),
                        program(&body),
                        class,
                    ));
                }
            }
        }
    }
    // Matrix products: a constant matrix and a parameter matrix (uniform).
    let mat =
        "(2.0, -1.0, 0.5, 3.0, 0.0, 1e-30, -0.0, 1e30, 1.5, 2.5, -3.5, 0.25, 0.0, 0.0, 0.0, 1.0)";
    for op in ["mulpoint", "mulvector"] {
        let body = format!("  %mm = const {mat} : matrix44\n  %x = {op} %mm, %p : vec3");
        rows.push((format!("{op} const"), program(&body), Class::Exact));
        let text = format!(
            "program \"row\" {{\n  param \"m\" matrix44 = {mat}\n{INPUTS}\n  %mm = param 0 : matrix44\n  %x = {op} %mm, %p : vec3\n  output r %x\n}}\n"
        );
        rows.push((format!("{op} param"), parse(&text).unwrap(), Class::Exact));
    }
    for ty in TYPES {
        let (x, y) = inputs(ty).unwrap();
        for c in ["%q", "%r"] {
            let body = format!("  %x = select {c}, {x}, {y} : {}", ty.name());
            rows.push((
                format!("select {} {c}", ty.name()),
                program(&body),
                Class::Exact,
            ));
        }
        for to in [Type::Bool, Type::Int, Type::Float] {
            if ops::convert_ok(ty, to) {
                let body = format!("  %x = convert {x} : {}", to.name());
                rows.push((
                    format!("convert {} → {}", ty.name(), to.name()),
                    program(&body),
                    Class::Exact,
                ));
            }
        }
        if ty.is_vector() {
            for i in 0..ty.width() {
                let body = format!("  %x = extract {x}, {i} : float");
                rows.push((
                    format!("extract {} {i}", ty.name()),
                    program(&body),
                    Class::Exact,
                ));
            }
            let body = format!("  %x = splat %b : {}", ty.name());
            rows.push((format!("splat {}", ty.name()), program(&body), Class::Exact));
        }
    }
    for &i in Intrinsic::ALL {
        let args = match i {
            Intrinsic::Noise2 => "%uv",
            Intrinsic::Noise3 | Intrinsic::CellNoise3 => "%p",
            Intrinsic::Fbm3 => "%n, %k, %a, %b",
            Intrinsic::RgbToHsv | Intrinsic::HsvToRgb => "%pc",
            Intrinsic::GgxAlbedo | Intrinsic::SheenAlbedo => "%a, %b",
            Intrinsic::DielectricAlbedo => "%a, %b, %c",
            // OSL/MaterialX noise: the point, then (octaves, lacunarity, diminish) or
            // (jitter, style, metric) from the fragment's hard values.
            osl => match ops::osl_intrinsic_operands(osl).expect("an OSL noise intrinsic") {
                [Type::Vec2] => "%uv",
                [Type::Vec3] => "%p",
                [Type::Float] => "%a",
                [Type::Vec3, Type::Float] => "%n, %b",
                [Type::Float, Type::Float] => "%a, %b",
                [Type::Vec2, Type::Vec2] => "%uv, %ba",
                [Type::Vec3, Type::Vec3] => "%p, %n",
                [Type::Vec3, Type::Float, Type::Vec3, Type::Float] => "%p, %a, %n, %b",
                [Type::Vec2, Type::Int, ..] => "%uv, %k, %a, %b",
                [Type::Vec3, Type::Int, ..] => "%n, %k, %a, %b",
                [Type::Vec2, ..] => "%uv, %a, %k, %m",
                _ => "%n, %b, %k, %m",
            },
        };
        let operands: Vec<Type> = ops::osl_intrinsic_operands(i).map_or_else(
            || match i {
                Intrinsic::Noise2 => vec![Type::Vec2],
                Intrinsic::Fbm3 => vec![Type::Vec3, Type::Int, Type::Float, Type::Float],
                Intrinsic::RgbToHsv | Intrinsic::HsvToRgb => vec![Type::Color],
                Intrinsic::GgxAlbedo | Intrinsic::SheenAlbedo => vec![Type::Float, Type::Float],
                Intrinsic::DielectricAlbedo => vec![Type::Float; 3],
                _ => vec![Type::Vec3],
            },
            <[Type]>::to_vec,
        );
        let rt = ops::intrinsic_type(i, &operands).expect("intrinsic type");
        let body = format!("  %x = call {} {args} : {}", i.name(), rt.name());
        rows.push((i.name().to_string(), program(&body), Class::Intrinsic));
    }
    // Worley noise in each metric and style, and jitter 1 as a constant (the GPU keeps the
    // jitter's 0.5s from folding).
    for name in ["mx_worley2_v3", "mx_worley3_v3"] {
        let p = if name.starts_with("mx_worley2") {
            "%uv"
        } else {
            "%p"
        };
        for (style, metric) in [(0, 0), (0, 1), (0, 2), (0, 3), (1, 0), (7, 9)] {
            let body = format!(
                "  %j = const 1.0 : float\n  %s = const {style} : int\n  %t = const {metric} : int\n  %x = call {name} {p}, %j, %s, %t : vec3"
            );
            rows.push((
                format!("{name} style {style} metric {metric}"),
                program(&body),
                Class::Intrinsic,
            ));
        }
    }
    for kind in XformKind::ALL {
        for from in Space::ALL {
            for to in Space::ALL {
                let body = format!(
                    "  %x = transform {} {} -> {} %n : vec3",
                    kind.name(),
                    from.name(),
                    to.name()
                );
                rows.push((
                    format!("transform {} {} → {}", kind.name(), from.name(), to.name()),
                    program(&body),
                    Class::Exact,
                ));
            }
        }
    }
    rows
}

#[test]
fn every_op_on_every_type() {
    let frags = hard_fragments();
    let env = env();
    let rows = op_table();
    assert!(rows.len() > 150, "{} rows", rows.len());
    for (name, p, class) in &rows {
        check_program(name, p, &env, u32::MAX, &frags, class.clone());
    }
}

/// Inputs aimed at the transcendentals (`ops::math`): the hard floats, f32 neighbours of
/// k·π/2 (k up to 2⁴⁰), the thresholds of `exp` and `pow`, the neighbours of ±1, then
/// random floats (every bit pattern, and uniform over [-20, 20]).
fn transcendental_floats() -> Vec<f32> {
    let mut v: Vec<f32> = HARD.to_vec();
    for k in [1i64, 2, 3, 7, 100, 12345, 1 << 20, 1 << 24, 1 << 40] {
        for sign in [1.0, -1.0] {
            let x = (sign * k as f64 * std::f64::consts::FRAC_PI_2) as f32;
            let b = x.to_bits();
            v.extend([x, f32::from_bits(b + 1), f32::from_bits(b - 1)]);
        }
    }
    v.extend([
        88.72,
        88.73,
        -103.9,
        -104.0,
        0.99999994,
        1.0000001,
        -0.99999994,
        709.0,
    ]);
    let mut rng = Rng(0x7A11_5CE7);
    for _ in 0..600 {
        v.push(f32::from_bits(rng.next() as u32));
        v.push((rng.next() >> 40) as f32 / (1u64 << 24) as f32 * 40.0 - 20.0);
    }
    v
}

/// Interpreter ≡ JIT scalar ≡ JIT batch, bit for bit, for every transcendental op (the
/// op table's rows) on [`transcendental_floats`] in every operand position: the JIT's
/// helpers call the interpreter's `ops::math` functions.
#[test]
fn transcendentals_are_bit_identical_on_the_cpu() {
    let xs = transcendental_floats();
    let n = xs.len();
    let frags: Vec<Fragment> = (0..n + 3)
        .map(|i| {
            let x = |o: usize| xs[(i * 13 + o * 7) % n];
            Fragment {
                p: [xs[i % n], x(1), x(2)],
                n: [x(3), xs[(i + 1) % n], x(4)],
                uv: [x(5), xs[i % n]],
                ..Fragment::default()
            }
        })
        .collect();
    let env = env();
    let rows: Vec<Row> = op_table()
        .into_iter()
        .filter(|(_, _, c)| matches!(c, Class::Op { .. }))
        .collect();
    assert!(rows.len() >= 10 * 4, "{} transcendental rows", rows.len());
    let cpu = |ut: &UnderTest| ut.tolerance == BIT_IDENTICAL;
    for (name, p, class) in &rows {
        check_program_on(name, p, &env, u32::MAX, &frags, class.clone(), &cpu);
    }
}

/// Regions and scene intrinsics: conditionals whose lanes diverge (and agree), nested, inside
/// the light loop and around it; light samples, ambient light, component masks, parameters
/// (class compilation), the prelude, textures.
#[test]
fn regions_and_scene_intrinsics() {
    let frags = hard_fragments();
    let env = env();
    // (name, body, class): light samples are intrinsics, `sin` and `pow` transcendentals.
    let rows: &[(&str, &str, Class)] = &[
        (
            "if diverging",
            "  %x0 = if %q {\n    %t = mul %a, %b : float\n    yield %t\n  } else {\n    %e = sqrt %b : float\n    yield %e\n  }\n  %x = proj %x0, 0 : float",
            Class::Exact,
        ),
        (
            "if uniform",
            "  %u = const true : bool\n  %x0 = if %u {\n    %t = div %a, %b : float\n    yield %t, %q\n  } else {\n    %e = floor %b : float\n    yield %e, %r\n  }\n  %x1 = proj %x0, 0 : float\n  %x2 = proj %x0, 1 : bool\n  %x3 = convert %x2 : float\n  %x = add %x1, %x3 : float",
            Class::Exact,
        ),
        (
            "if nested",
            "  %x0 = if %q {\n    %i0 = if %r {\n      %t = sin %a : float\n      %tv = splat %t : vec3\n      yield %tv, %k\n    } else {\n      %t2 = add %p, %n : vec3\n      yield %t2, %m\n    }\n    %y0 = proj %i0, 0 : vec3\n    %y1 = proj %i0, 1 : int\n    yield %y0, %y1\n  } else {\n    %e = normalize %n : vec3\n    %ei = div %k, %m : int\n    yield %e, %ei\n  }\n  %x1 = proj %x0, 0 : vec3\n  %x2 = proj %x0, 1 : int\n  %x3 = convert %x2 : float\n  %x4 = splat %x3 : vec3\n  %x = add %x1, %x4 : vec3",
            Class::MixedExcept {
                why: "sin of |P.x| > 1e4",
                excused: |f| f.p[0].abs() > 1e4 || f.p[0].is_nan(),
            },
        ),
        (
            "illuminance",
            "  %l0 = illuminance %p {\n    %L = light.L : vec3\n    %C = light.Cl : color\n    %d = dot %n, %L : float\n    %z = const 0.0 : float\n    %mx = max %d, %z : float\n    %s = splat %mx : color\n    %y = mul %C, %s : color\n    yield %y, %d\n  }\n  %l1 = proj %l0, 0 : color\n  %l2 = proj %l0, 1 : float\n  %amb = ambient : color\n  %s2 = splat %l2 : color\n  %x3 = add %l1, %amb : color\n  %x = add %x3, %s2 : color",
            Class::Intrinsic,
        ),
        (
            "if inside illuminance, illuminance inside if",
            "  %x0 = if %r {\n    %l0 = illuminance %n {\n      %L = light.L : vec3\n      %C = light.Cl : color\n      %d = dot %p, %L : float\n      %z = const 0.0 : float\n      %g = gt %d, %z : bool\n      %i0 = if %g {\n        %w = pow %d, %b : float\n        %ws = splat %w : color\n        %y = mul %C, %ws : color\n        yield %y\n      } else {\n        %y2 = const (0.0, -0.0, 1.0) : color\n        yield %y2\n      }\n      %yy = proj %i0, 0 : color\n      yield %yy\n    }\n    %l1 = proj %l0, 0 : color\n    yield %l1\n  } else {\n    yield %nc\n  }\n  %x = proj %x0, 0 : color",
            Class::Mixed,
        ),
    ];
    for (name, body, class) in rows {
        let p = program(body);
        check_program(name, &p, &env, u32::MAX, &frags, class.clone());
    }
    // Without lights, the loop runs zero times; with only an ambient light, it skips it.
    let p = program(rows[3].1);
    for lights in [Vec::new(), vec![env.lights[1].desc.clone()]] {
        let e = ShadeEnv {
            lights: lights
                .iter()
                .map(shadenet_runtime::Light::from_desc)
                .collect(),
            ..env.clone()
        };
        check_program(
            "illuminance, no direct light",
            &p,
            &e,
            u32::MAX,
            &frags,
            Class::Exact,
        );
    }
    // Component masks, parameters (class compilation) and the prelude.
    let text = r#"program "uniforms" {
  components diffuse specular
  param "k" float = 2.5
  param "c" color = (0.25, -0.0, 1e-40)
  param "on" bool = true
  param "n" int = -3
  prelude {
    %k = param 0 : float
    %c3 = const 3.0 : float
    %kk = mul %k, %c3 : float
    %ks = splat %kk : color
    %cc = param 1 : color
    %pre = add %ks, %cc : color
    %on = param 2 : bool
    %ni = param 3 : int
  }
  %p = stream P : vec3
  %a = extract %p, 0 : float
  %ac = splat %a : color
  %d = component_enabled diffuse : bool
  %s = component_enabled specular : bool
  %x0 = select %d, %pre, %ac : color
  %x1 = select %s, %ac, %x0 : color
  %x2 = select %on, %x1, %x0 : color
  %nf = convert %ni : float
  %x3 = mul %nf, %a : float
  output out[diffuse] %x1
  output out[specular] %x2
  output extra %x3
  output flag %on
  output count %ni
}
"#;
    let p = parse(text).unwrap();
    for mask in [u32::MAX, 0, 1, 2] {
        check_program("uniforms", &p, &env, mask, &frags, Class::Exact);
    }
}

/// Matrices as values: one constructed in the prelude from a parameter, one per fragment
/// from the streams, chosen per fragment by a select and by an `if`, read by extract and
/// mulpoint, and written as matrix33 and matrix44 outputs.
#[test]
fn matrices() {
    let env = env();
    let frags = hard_fragments();
    let text = r#"program "matrices" {
  param "m" matrix44 = (1.0, 0.0, 0.0, 2.0, 0.0, 1.0, 0.0, -3.0, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0, 0.0, 1.0)
  param "s" float = 0.5
  prelude {
    %pm = param 0 : matrix44
    %s = param 1 : float
    %m00 = extract %pm, 0 : float
    %ps = mul %m00, %s : float
    %z = const 0.0 : float
    %scale = construct %ps, %z, %z, %z, %ps, %z, %z, %z, %ps : matrix33
  }
  %p = stream P : vec3
  %n = stream N : vec3
  %px = extract %p, 0 : float
  %py = extract %p, 1 : float
  %pz = extract %p, 2 : float
  %nx = extract %n, 0 : float
  %ny = extract %n, 1 : float
  %nz = extract %n, 2 : float
  %one = const 1.0 : float
  %zero = const 0.0 : float
  %vm = construct %px, %py, %pz, %nx, %ny, %nz, %py, %pz, %one : matrix33
  %big = construct %px, %py, %pz, %nx, %ny, %nz, %zero, %one, %pz, %px, %one, %zero, %zero, %zero, %zero, %one : matrix44
  %c = gt %px, %py : bool
  %pick = select %c, %vm, %scale : matrix33
  %i44 = if %c {
    yield %big
  } else {
    yield %pm
  }
  %sel44 = proj %i44, 0 : matrix44
  %e = extract %pick, 4 : float
  %q = mulpoint %sel44, %n : vec3
  %r = mulpoint %pm, %p : vec3
  output pick %pick
  output sel %sel44
  output e %e
  output q %q
  output r %r
  output scale %scale
}
"#;
    let p = parse(text).unwrap();
    check_program("matrices", &p, &env, u32::MAX, &frags, Class::Exact);
    let (o, _) = opt::run(&p, &Specialization::default());
    check_program(
        "matrices (optimized)",
        &o,
        &env,
        u32::MAX,
        &frags,
        Class::Exact,
    );
}

#[test]
fn textures() {
    let dir = std::env::temp_dir().join(format!("shadenet-backends-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("t.png");
    let px: Vec<u8> = vec![
        255, 0, 0, 255, 0, 255, 0, 255, 30, 60, 90, 128, //
        0, 0, 255, 255, 255, 255, 255, 0, 10, 20, 30, 40,
    ];
    image::save_buffer(&path, &px, 3, 2, image::ExtendedColorType::Rgba8).unwrap();
    let text = format!(
        "program \"tex\" {{\n  texture {:?}\n  %uv = stream uv : vec2\n  %t = texture #0 %uv : color\n  %a = texture.alpha #0 %uv : float\n  output c %t\n  output a %a\n}}\n",
        path.to_string_lossy()
    );
    let p = parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    check_program(
        "texture",
        &p,
        &env(),
        u32::MAX,
        &hard_fragments(),
        Class::Intrinsic,
    );
}

fn examples() -> Vec<std::path::PathBuf> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/networks");
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    v.sort();
    v
}

/// Every example network, optimized (default, and with CSE off), unoptimized and with one
/// component active, over a grid whose size is not a multiple of 4.
#[test]
fn every_example_network() {
    let (w, h) = (23, 17);
    let frags: Vec<Fragment> = (0..h)
        .flat_map(|y| (0..w).map(move |x| shadenet::shade::grid_fragment(x, y, w, h)))
        .collect();
    for path in examples() {
        let c = shadenet::load_network(&path).unwrap();
        let mut lights = c.lights.clone();
        if lights.is_empty() {
            lights.push(LightDesc {
                name: "key".into(),
                kind: LightKind::Point {
                    position: [1.0, 1.0, 2.0],
                },
                power: [20.0; 3],
            });
        }
        let env = shadenet::shade::grid_env(&lights);
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let no_cse = Specialization {
            passes: Passes {
                cse: false,
                ..Passes::default()
            },
            ..Specialization::default()
        };
        let class_compile = Specialization {
            bake: false,
            ..Specialization::default()
        };
        let first = Specialization {
            components: 1,
            ..Specialization::default()
        };
        for (label, spec) in [
            ("default", Specialization::default()),
            ("no cse", no_cse),
            ("class", class_compile),
            ("first component", first),
        ] {
            let (p, _) = opt::run(&c.program, &spec);
            let what = format!("{name} ({label})");
            check_program(&what, &p, &env, spec.components, &frags, Class::Mixed);
        }
        check_program(
            &format!("{name} (unoptimized)"),
            &c.program,
            &env,
            u32::MAX,
            &frags,
            Class::Mixed,
        );
    }
}

/// Every OSL shader of our own that lowers (`examples/shaders/*.osl`,
/// `lang/tests/shaders/*.osl`: Perlin and simplex noise, splines and their inverse,
/// closures, loops, `calculatenormal`), optimized and unoptimized, on every back end, lit by
/// one point light: the OSL test set through the parity suite.
#[test]
fn every_osl_shader_of_ours() {
    let (w, h) = (23, 17);
    let frags: Vec<Fragment> = (0..h)
        .flat_map(|y| (0..w).map(move |x| shadenet::shade::grid_fragment(x, y, w, h)))
        .collect();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut paths: Vec<_> = ["examples/shaders", "lang/tests/shaders"]
        .iter()
        .flat_map(|d| std::fs::read_dir(root.join(d)).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "osl"))
        // The parser's test shader (`lang/tests/parse.rs`): it sums a closure in a loop whose
        // count is a parameter, which the lowering refuses with an error that says so.
        .filter(|p| !p.ends_with("layered.osl"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 6, "the OSL shaders: {paths:?}");
    let lights = [LightDesc {
        name: "key".into(),
        kind: LightKind::Point {
            position: [1.0, 1.0, 2.0],
        },
        power: [20.0; 3],
    }];
    let env = shadenet::shade::grid_env(&lights);
    for path in paths {
        let c = shadenet::shader::load(&path, &[], &[])
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let spec = Specialization::default();
        let (p, _) = opt::run(&c.program, &spec);
        check_program(&name, &p, &env, spec.components, &frags, Class::Mixed);
        let what = format!("{name} (unoptimized)");
        check_program(&what, &c.program, &env, u32::MAX, &frags, Class::Mixed);
    }
}

// ---- random programs ----

/// A small deterministic generator (xorshift).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn pick<'a, T>(&mut self, xs: &'a [T]) -> &'a T {
        &xs[self.below(xs.len())]
    }
}

/// Builds a random valid program as IR text: float, vec3 and bool values from the streams
/// and constants, arithmetic, transcendentals, selects, conditionals (possibly nested) and
/// light loops. The property generator of the partial-evaluation branch produces networks;
/// its programs go through [`check_program`] the same way.
struct Gen {
    rng: Rng,
    next: usize,
    text: String,
}

impl Gen {
    fn label(&mut self) -> String {
        self.next += 1;
        format!("%g{}", self.next)
    }

    fn line(&mut self, indent: usize, s: String) {
        self.text.push_str(&" ".repeat(indent * 2 + 2));
        self.text.push_str(&s);
        self.text.push('\n');
    }

    /// Emits `n` values into the current block; `pools` are (floats, vec3s, bools) visible.
    fn block(
        &mut self,
        indent: usize,
        n: usize,
        pools: &mut (Vec<String>, Vec<String>, Vec<String>),
        depth: usize,
        in_light: bool,
    ) {
        for _ in 0..n {
            let choice = self.rng.below(if depth < 2 { 14 } else { 12 });
            let x = self.label();
            match choice {
                0 => {
                    let c = *self.rng.pick(HARD);
                    self.line(indent, format!("{x} = const {} : float", lit(c)));
                    pools.0.push(x);
                }
                1..=3 => {
                    let op = *self.rng.pick(&[
                        "add", "sub", "mul", "div", "min", "max", "mod", "pow", "atan2",
                    ]);
                    let a = self.rng.pick(&pools.0).clone();
                    let b = self.rng.pick(&pools.0).clone();
                    self.line(indent, format!("{x} = {op} {a}, {b} : float"));
                    pools.0.push(x);
                }
                4 => {
                    let op = *self.rng.pick(&[
                        "neg", "abs", "floor", "fract", "sqrt", "sin", "exp", "log", "acos", "ceil",
                    ]);
                    let a = self.rng.pick(&pools.0).clone();
                    self.line(indent, format!("{x} = {op} {a} : float"));
                    pools.0.push(x);
                }
                5 => {
                    let op = *self.rng.pick(&["add", "sub", "mul", "div", "cross", "min"]);
                    let a = self.rng.pick(&pools.1).clone();
                    let b = self.rng.pick(&pools.1).clone();
                    self.line(indent, format!("{x} = {op} {a}, {b} : vec3"));
                    pools.1.push(x);
                }
                6 => {
                    let op = *self.rng.pick(&["dot", "distance"]);
                    let a = self.rng.pick(&pools.1).clone();
                    let b = self.rng.pick(&pools.1).clone();
                    self.line(indent, format!("{x} = {op} {a}, {b} : float"));
                    pools.0.push(x);
                }
                7 => {
                    let op = *self.rng.pick(&["normalize", "floor", "neg"]);
                    let a = self.rng.pick(&pools.1).clone();
                    self.line(indent, format!("{x} = {op} {a} : vec3"));
                    pools.1.push(x);
                }
                8 => {
                    let a = self.rng.pick(&pools.0).clone();
                    let b = self.rng.pick(&pools.0).clone();
                    let c = self.rng.pick(&pools.0).clone();
                    self.line(indent, format!("{x} = construct {a}, {b}, {c} : vec3"));
                    pools.1.push(x);
                }
                9 => {
                    let op = *self.rng.pick(&["lt", "le", "gt", "ge", "eq", "ne"]);
                    let a = self.rng.pick(&pools.0).clone();
                    let b = self.rng.pick(&pools.0).clone();
                    self.line(indent, format!("{x} = {op} {a}, {b} : bool"));
                    pools.2.push(x);
                }
                10 => {
                    let c = self.rng.pick(&pools.2).clone();
                    let a = self.rng.pick(&pools.1).clone();
                    let b = self.rng.pick(&pools.1).clone();
                    self.line(indent, format!("{x} = select {c}, {a}, {b} : vec3"));
                    pools.1.push(x);
                }
                11 => {
                    let a = self.rng.pick(&pools.1).clone();
                    let i = self.rng.below(3);
                    self.line(indent, format!("{x} = extract {a}, {i} : float"));
                    pools.0.push(x);
                }
                12 => {
                    // A conditional yielding a float and a vec3.
                    let c = self.rng.pick(&pools.2).clone();
                    self.line(indent, format!("{x} = if {c} {{"));
                    for arm in 0..2 {
                        let mut inner = pools.clone();
                        let len = 1 + self.rng.below(5);
                        self.block(indent + 1, len, &mut inner, depth + 1, in_light);
                        let f = self.rng.pick(&inner.0).clone();
                        let v = self.rng.pick(&inner.1).clone();
                        self.line(indent + 1, format!("yield {f}, {v}"));
                        if arm == 0 {
                            self.line(indent, "} else {".into());
                        }
                    }
                    self.line(indent, "}".into());
                    let f = self.label();
                    let v = self.label();
                    self.line(indent, format!("{f} = proj {x}, 0 : float"));
                    self.line(indent, format!("{v} = proj {x}, 1 : vec3"));
                    pools.0.push(f);
                    pools.1.push(v);
                }
                _ => {
                    // A light loop (not nested in another).
                    if in_light {
                        self.line(indent, format!("{x} = const 0.5 : float"));
                        pools.0.push(x);
                        continue;
                    }
                    let pt = self.rng.pick(&pools.1).clone();
                    self.line(indent, format!("{x} = illuminance {pt} {{"));
                    let mut inner = pools.clone();
                    let (l, cl) = (self.label(), self.label());
                    self.line(indent + 1, format!("{l} = light.L : vec3"));
                    self.line(indent + 1, format!("{cl} = light.Cl : color"));
                    let clv = self.label();
                    self.line(indent + 1, format!("{clv} = extract {cl}, 0 : float"));
                    inner.1.push(l);
                    inner.0.push(clv);
                    let len = 1 + self.rng.below(4);
                    self.block(indent + 1, len, &mut inner, depth + 1, true);
                    let f = self.rng.pick(&inner.0).clone();
                    let v = self.rng.pick(&inner.1).clone();
                    self.line(indent + 1, format!("yield {f}, {v}"));
                    self.line(indent, "}".into());
                    let (f2, v2) = (self.label(), self.label());
                    self.line(indent, format!("{f2} = proj {x}, 0 : float"));
                    self.line(indent, format!("{v2} = proj {x}, 1 : vec3"));
                    pools.0.push(f2);
                    pools.1.push(v2);
                }
            }
        }
    }
}

/// A float literal of the IR text.
fn lit(x: f32) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{:?}", x as f64)
    }
}

/// A random program from `seed`.
fn random_program(seed: u64) -> Program {
    let mut g = Gen {
        rng: Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1),
        next: 0,
        text: String::new(),
    };
    let mut pools = (
        vec!["%a".to_string(), "%b".into(), "%c".into()],
        vec!["%p".to_string(), "%n".into()],
        vec!["%q".to_string(), "%r".into()],
    );
    let len = 8 + g.rng.below(24);
    g.block(0, len, &mut pools, 0, false);
    let f = g.rng.pick(&pools.0).clone();
    let v = g.rng.pick(&pools.1).clone();
    let text = format!(
        "program \"random{seed}\" {{\n{INPUTS}\n{}  output f {f}\n  output v {v}\n}}\n",
        g.text
    );
    parse(&text).unwrap_or_else(|e| panic!("seed {seed}: {e}\n{text}"))
}

#[test]
fn random_programs() {
    let frags: Vec<Fragment> = hard_fragments().into_iter().step_by(7).collect();
    let env = env();
    for seed in 1..=60 {
        let p = random_program(seed);
        check_program_on(
            &format!("random program {seed}"),
            &p,
            &env,
            u32::MAX,
            &frags,
            Class::Mixed,
            &|ut| seed % ut.random_every == 0,
        );
    }
}

// ---- the back-end contract ----

/// An op the JIT does not compile (every op of a valid program compiles since matrices are
/// values: `JitOptions::refuse` makes one unsupported) makes it fall back to the interpreter
/// for that material, say which op and why, and give the interpreter's results; with
/// fallback off it is an error, never a panic. Without the refusal the same program (a
/// matrix chosen per fragment, once the JIT's gap) compiles and agrees bit for bit.
#[test]
fn unsupported_op_falls_back_to_the_interpreter() {
    let text = "program \"mat\" {\n  %p = stream P : vec3\n  %a = extract %p, 0 : float\n  %z = const 0.0 : float\n  %q = lt %a, %z : bool\n  %m1 = const (1.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0) : matrix44\n  %m2 = const (2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0) : matrix44\n  %m = select %q, %m1, %m2 : matrix44\n  %x = mulpoint %m, %p : vec3\n  output r %x\n}\n";
    let p = parse(text).unwrap();
    shadenet_graph::ir::validate(&p).unwrap();
    let refuse = vec!["select".to_string()];
    let quiet = JitBackend::with_options(JitOptions {
        log_fallback: false,
        refuse: refuse.clone(),
        ..JitOptions::default()
    });
    let m = quiet.compile_program(&p, Duration::ZERO).unwrap();
    let why = m.info().fallback.clone().expect("a fallback");
    assert_eq!(m.info().backend, "interp");
    assert!(why.contains("select") && why.contains("refused"), "{why}");
    let frags = hard_fragments();
    let env = env();
    let reference = InterpBackend.compile_program(&p, Duration::ZERO).unwrap();
    let (a, _) = shade_all(&*m, Drive::Batch, &env, u32::MAX, &frags);
    let (b, _) = shade_all(&*reference, Drive::Scalar, &env, u32::MAX, &frags);
    assert_eq!(
        a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    );
    let strict = JitBackend::with_options(JitOptions {
        fallback: false,
        refuse,
        ..JitOptions::default()
    });
    let err = strict
        .compile_program(&p, Duration::ZERO)
        .err()
        .expect("an error")
        .to_string();
    assert!(
        err.contains("select") && err.contains("not supported"),
        "{err}"
    );
    let full = jit(OptLevel::Auto)
        .compile_program(&p, Duration::ZERO)
        .unwrap();
    assert_eq!(full.info().backend, "jit");
    assert!(full.info().fallback.is_none());
    let (c, _) = shade_all(&*full, Drive::Batch, &env, u32::MAX, &frags);
    assert_eq!(
        c.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        b.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    );
}

/// One compiled material shaded from every rayon thread at once gives the results of one
/// thread.
#[test]
fn compiled_materials_are_shared_across_threads() {
    use rayon::prelude::*;
    let c = shadenet::load_network(&examples()[0]).unwrap();
    let (p, _) = opt::run(&c.program, &Specialization::default());
    let m: Arc<dyn Material> = jit(OptLevel::Auto)
        .compile_program(&p, Duration::ZERO)
        .unwrap();
    let env = shadenet::shade::grid_env(&c.lights);
    let frags: Vec<Fragment> = (0..64)
        .flat_map(|y| (0..64).map(move |x| shadenet::shade::grid_fragment(x, y, 64, 64)))
        .collect();
    let (serial, _) = shade_all(&*m, Drive::Batch, &env, u32::MAX, &frags);
    let w = m.width();
    let mut parallel = vec![0.0f32; serial.len()];
    parallel
        .par_chunks_mut(w * 16)
        .zip(frags.par_chunks(16))
        .for_each(|(out, fs)| {
            if fs[0].p[0] < 0.0 {
                shade_batch(&*m, &env, u32::MAX, fs, out);
            } else {
                for (f, o) in fs.iter().zip(out.chunks_mut(w)) {
                    m.shade(&ShadeCtx::new(*f, &env), o);
                }
            }
        });
    assert_eq!(serial, parallel);
}

#[test]
fn the_cache_compiles_each_material_once() {
    let c = shadenet::load_network(&examples()[0]).unwrap();
    let cache = MaterialCache::new();
    let backend = jit(OptLevel::Auto);
    let spec = Specialization::default();
    let a = cache.get_or_compile(&backend, &c.program, &spec).unwrap();
    let b = cache.get_or_compile(&backend, &c.program, &spec).unwrap();
    assert!(Arc::ptr_eq(&a, &b));
    let other = Specialization {
        components: 1,
        ..spec.clone()
    };
    let d = cache.get_or_compile(&backend, &c.program, &other).unwrap();
    assert!(!Arc::ptr_eq(&a, &d));
    let e = cache
        .get_or_compile(&InterpBackend, &c.program, &spec)
        .unwrap();
    assert!(!Arc::ptr_eq(&a, &e));
    assert_eq!(cache.len(), 3);
    let stats = a.info().stats;
    assert!(stats.code_bytes > 0 && stats.ir_insts > 0, "{stats}");
}

// ---- scene services: trace, occlusion, light visibility ----

/// Shades every fragment through the scalar entry with `scene`.
fn shade_with_scene(
    m: &dyn Material,
    env: &ShadeEnv,
    frags: &[Fragment],
    scene: Option<&dyn SceneServices>,
) -> (Vec<f32>, u64) {
    let w = m.width();
    let mut out = vec![f32::NAN; w * frags.len()];
    let mut bad = 0;
    for (f, o) in frags.iter().zip(out.chunks_mut(w)) {
        let ctx = ShadeCtx {
            frag: *f,
            env,
            mask: u32::MAX,
            scene,
        };
        bad += m.shade(&ctx, o) as u64;
    }
    (out, bad)
}

/// Every back end against the interpreter with a scene: the scalar entry with the scene
/// (bit for bit), the batch entry (no scene) against the interpreter without one, the
/// GPU's `shade_many` with the scene (its host steps ask it) within its tolerance for
/// `class`. Returns whether the scene changed the interpreter's results.
fn check_scene(
    what: &str,
    program: &Program,
    env: &ShadeEnv,
    frags: &[Fragment],
    class: &Class,
) -> bool {
    check_scene_on(what, program, env, frags, class, &|_| true)
}

/// [`check_scene`] on the back ends `include` accepts.
fn check_scene_on(
    what: &str,
    program: &Program,
    env: &ShadeEnv,
    frags: &[Fragment],
    class: &Class,
    include: &dyn Fn(&UnderTest) -> bool,
) -> bool {
    shadenet_graph::ir::validate(program).unwrap_or_else(|e| panic!("{what}: {e}\n{program}"));
    // A hardware GPU's traced directions differ by ulps: it is asked a smooth scene.
    let scene = HashScene::new(gpu().is_some() && hardware_contract());
    let reference = InterpBackend
        .compile_program(program, Duration::ZERO)
        .unwrap();
    let with = shade_with_scene(&*reference, env, frags, Some(&scene));
    let without = shade_with_scene(&*reference, env, frags, None);
    assert!(scene.calls() > 0, "{what}: the scene was never asked");
    for ut in backends().into_iter().filter(|ut| include(ut)) {
        let m = ut
            .backend
            .compile_program(program, Duration::ZERO)
            .unwrap_or_else(|e| panic!("{what}: {}: {e}", ut.name));
        let (got, want) = match ut.drive {
            Drive::Scalar => (shade_with_scene(&*m, env, frags, Some(&scene)), &with),
            Drive::Batch => {
                let mut out = vec![f32::NAN; m.width() * frags.len()];
                let bad = shade_batch(&*m, env, u32::MAX, frags, &mut out);
                ((out, bad), &without)
            }
            Drive::Many => {
                let mut out = vec![f32::NAN; m.width() * frags.len()];
                let r = shade_many_unpacked(&*m, env, u32::MAX, Some(&scene), frags, &mut out);
                ran_on_the_device(&*m, &r);
                ((out, r.nonfinite), &with)
            }
        };
        let seen = Seen {
            what,
            program,
            frags,
            width: m.width().max(1),
            got: (&got.0, got.1),
            want: (&want.0, want.1),
        };
        verify(&ut, class, &seen, None);
    }
    with.0
        .iter()
        .zip(&without.0)
        .any(|(a, b)| a.to_bits() != b.to_bits())
}

/// The class of a scene program of [`scene_services_match_the_interpreter`]: phong (mirror,
/// glass) and blinn raise to a power for their highlights; the others are exact on the GPU
/// (light samples, traces and occlusion are host steps).
fn scene_class(name: &str) -> Class {
    match name {
        "mirror" | "glass" | "blinn" => Class::Mixed,
        "lambert" | "ambient occlusion" => Class::Intrinsic,
        _ => Class::Exact,
    }
}

fn surface(name: &str, inputs: &[(&str, ConstValue)]) -> Program {
    let inputs: Vec<(&str, Literal)> = inputs
        .iter()
        .map(|(k, v)| (*k, Literal::Const(v.clone())))
        .collect();
    lower_single(&NodeLibrary::standard(), name, Type::Float, &inputs).unwrap()
}

/// Fragments on the z = 0 plane seen from outside and from inside (where a dense medium
/// reflects totally past its critical angle) at many angles, grazing ones included, plus
/// the hard fragments.
fn scene_fragments() -> Vec<Fragment> {
    let mut v = Vec::new();
    for k in 0..24 {
        let a = k as f32 / 24.0 * std::f32::consts::FRAC_PI_2;
        for inside in [false, true] {
            let z = if inside { a.cos() } else { -a.cos() };
            v.push(Fragment {
                p: [0.1 * k as f32 - 1.0, 0.05 * k as f32, 0.0],
                n: [0.0, 0.0, if inside { -1.0 } else { 1.0 }],
                ng: [0.0, 0.0, 1.0],
                i: [a.sin(), 0.0, z],
                uv: [0.5, 0.5],
                dpdu: [1.0, 0.0, 0.0],
                dpdv: [0.0, 1.0, 0.0],
                ray_type: shadenet_graph::ir::RAY_CAMERA,
                ray_depth: k % 3,
                seed: 1000 + k as u32,
                ..Fragment::default()
            });
        }
    }
    v.extend(hard_fragments());
    v
}

fn scene_env() -> ShadeEnv {
    let mut env = env();
    let more = [
        LightDesc {
            name: "quad".into(),
            kind: LightKind::Quad {
                corner: [-1.0, -1.0, 2.0],
                edge_u: [0.0, 2.0, 0.0],
                edge_v: [2.0, 0.0, 0.0],
                samples: 5,
            },
            power: [1.5; 3],
        },
        LightDesc {
            name: "sky".into(),
            kind: LightKind::Environment {
                samples: 3,
                map: None,
            },
            power: [0.2, 0.3, 0.5],
        },
    ];
    env.lights
        .extend(more.iter().map(shadenet_runtime::Light::from_desc));
    env
}

/// Mirror, glass (with total internal reflection), shadowed lights and ambient occlusion
/// networks, and IR exercising the ops directly: the JIT's scalar entry equals the
/// interpreter with a scene, its batch entry the interpreter without one, bit for bit.
#[test]
fn scene_services_match_the_interpreter() {
    let frags = scene_fragments();
    let env = scene_env();
    let color = |r, g, b| ConstValue::Color([r, g, b]);
    let programs = [
        (
            "mirror",
            surface("phong", &[("reflectivity", ConstValue::Float(1.0))]),
        ),
        (
            "glass",
            surface(
                "phong",
                &[
                    ("reflectivity", ConstValue::Float(0.2)),
                    ("refractions", ConstValue::Bool(true)),
                    ("transparency", color(1.0, 1.0, 1.0)),
                    ("refractiveIndex", ConstValue::Float(1.5)),
                ],
            ),
        ),
        (
            "lambert",
            surface("lambert", &[("color", color(0.9, 0.6, 0.3))]),
        ),
        ("blinn", surface("blinn", &[])),
        (
            "ambient occlusion",
            surface(
                "ambientOcclusion",
                &[
                    ("bright", color(1.0, 0.5, 0.0)),
                    ("dark", color(0.0, 0.0, 1.0)),
                    ("maxDistance", ConstValue::Float(2.0)),
                ],
            ),
        ),
        (
            "ops",
            parse(
                r#"program "ops" {
  %p = stream P : vec3
  %n = stream N : vec3
  %i = stream I : vec3
  %k = stream raydepth : int
  %x = extract %p, 0 : float
  %t = trace reflection %i : color
  %u = trace diffuse %n : color
  %o = occlusion %n, %k, %x : float
  %l = illuminance %p {
    %v = light.visible : float
    %c = light.Cl : color
    %b = gt %v, %x : bool
    %r = if %b {
      %w0 = light.visible : float
      %w = splat %w0 : color
      %s = mul %c, %w : color
      yield %s
    } else {
      yield %c
    }
    %s1 = proj %r, 0 : color
    yield %v, %s1
  }
  %vis = proj %l, 0 : float
  %cl = proj %l, 1 : color
  %m = illuminance %n {
    %c2 = light.Cl : color
    yield %c2
  }
  %cl2 = proj %m, 0 : color
  output t %t
  output u %u
  output o %o
  output vis %vis
  output cl %cl
  output cl2 %cl2
}
"#,
            )
            .unwrap(),
        ),
    ];
    for (name, p) in &programs {
        let class = &scene_class(name);
        assert!(
            check_scene(&format!("{name} (unoptimized)"), p, &env, &frags, class),
            "{name}: the scene changes nothing"
        );
        let (o, _) = opt::run(p, &Specialization::default());
        check_scene(&format!("{name} (optimized)"), &o, &env, &frags, class);
    }
}

// ---- the GPU's pass partitioning ----

/// The same programs partitioned into one fused kernel and into 2, 3, 5 and 8 passes give
/// the same bits: values cross passes through the device's temporary buffer unchanged, and
/// no plan lets the shader compiler rewrite arithmetic across ops differently. Programs:
/// every example network (optimized) and random programs. (The cost model's own plans are
/// `gpu/tests/backend.rs`'s.)
#[test]
fn gpu_pass_plans_agree() {
    let Some(_) = gpu() else {
        return;
    };
    let frags: Vec<Fragment> = hard_fragments().into_iter().step_by(3).collect();
    let env = env();
    let hardware_contract = hardware_contract();
    let mut programs: Vec<(String, Program)> = Vec::new();
    for path in examples() {
        let c = shadenet::load_network(&path).unwrap();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let (o, _) = opt::run(&c.program, &Specialization::default());
        programs.push((format!("{name} (optimized)"), o));
    }
    for seed in [3, 7, 11, 19, 23, 42] {
        programs.push((format!("random program {seed}"), random_program(seed)));
    }
    let plans = [
        ("fused", PassMode::Fused, GpuOptions::default().op_budget),
        (
            "2 passes",
            PassMode::Count(2),
            GpuOptions::default().op_budget,
        ),
        (
            "3 passes",
            PassMode::Count(3),
            GpuOptions::default().op_budget,
        ),
        (
            "5 passes",
            PassMode::Count(5),
            GpuOptions::default().op_budget,
        ),
        (
            "8 passes",
            PassMode::Count(8),
            GpuOptions::default().op_budget,
        ),
    ];
    let mut partitioned = 0;
    for (what, program) in &programs {
        let mut reference: Option<(Vec<f32>, u64)> = None;
        let mut counts = Vec::new();
        for (label, passes, op_budget) in plans {
            let backend = GpuBackend::new(
                GpuOptions {
                    passes,
                    op_budget,
                    ..GpuOptions::default()
                },
                Arc::new(InterpBackend),
            )
            .expect("the device")
            .without_fallback();
            let m = backend
                .compile_gpu(program, Duration::ZERO)
                .unwrap_or_else(|e| panic!("{what} ({label}): {e}\n{program}"));
            counts.push((label, m.plan().passes()));
            let (got, bad) = shade_all(&m, Drive::Many, &env, u32::MAX, &frags);
            match &reference {
                None => reference = Some((got, bad)),
                Some((want, _)) if hardware_contract => {
                    // The driver contracts each plan's kernels its own way.
                    let streams = hardware::streams_read(program);
                    let compared = |f: usize| hardware::fragment_in_domain(&frags[f], &streams);
                    if let Err(e) = hardware::check_outputs(&got, want, m.width(), &compared) {
                        panic!("{what}: {label} against the fused kernel: hardware contract: {e}");
                    }
                }
                Some((want, want_bad)) => {
                    let w = m.width().max(1);
                    for (i, (g, x)) in got.iter().zip(want).enumerate() {
                        assert!(
                            g.to_bits() == x.to_bits(),
                            "{what}: {label} differs from the fused kernel at fragment {} \
                             output float {}: {g:?} vs {x:?}\n{}",
                            i / w,
                            i % w,
                            m.plan()
                        );
                    }
                    assert_eq!(bad, *want_bad, "{what} ({label}): non-finite count");
                }
            }
        }
        if counts.iter().any(|(_, n)| *n != counts[0].1) {
            partitioned += 1;
        }
    }
    // The plans must actually cut the programs differently for the check to mean anything.
    assert!(
        partitioned * 2 >= programs.len(),
        "only {partitioned} of {} programs were cut differently by different plans",
        programs.len()
    );
}

#[path = "backends/mtlx.rs"]
mod mtlx;

/// The specular lobes (DESIGN §12, issue 15) as whole programs on every back end against the
/// interpreter: `eval`, `sample` and `albedo` of a rough `RT` dielectric (viewer inside and
/// outside), a gold conductor and a `T` generalized Schlick, directions and random numbers
/// taken from the hard fragments' streams; each also under a thin film; and the Phong and
/// Blinn lobes of the Maya surfaces.
#[test]
fn specular_lobes_on_every_backend() {
    use shadenet_graph::closure::{LobeKind, ScatterMode, ThinFilm};
    use shadenet_graph::ir::{Builder, Stream};
    let frags = hard_fragments();
    let env = env();
    let cases = [
        ("dielectric RT", 0, None),
        ("conductor", 1, None),
        ("schlick T", 2, None),
        ("filmed dielectric RT", 0, Some([380.0, 1.33])),
        ("filmed conductor", 1, Some([450.0, 1.8])),
        ("filmed schlick T", 2, Some([520.0, 1.6])),
        ("phong", 3, None),
        ("blinn", 4, None),
    ];
    for (name, which, film) in cases {
        let mut b = Builder::new(name);
        let rough = b.constant(ConstValue::Vec2([0.3, 0.1]));
        let thin_film = film.map(|[t, ior]: [f64; 2]| ThinFilm {
            thickness: b.float(t),
            ior: b.float(ior),
        });
        let kind = match which {
            0 => LobeKind::Dielectric {
                tint: b.color([1.0, 0.9, 0.8]),
                ior: b.float(1.5),
                roughness: rough,
                scatter_mode: ScatterMode::RT,
                thin_film,
            },
            1 => LobeKind::Conductor {
                ior: b.color([0.18, 0.42, 1.37]),
                extinction: b.color([3.42, 2.35, 1.77]),
                roughness: rough,
                thin_film,
            },
            2 => LobeKind::GeneralizedSchlick {
                color0: b.color([0.04, 0.05, 0.06]),
                color82: b.color([1.0, 1.0, 1.0]),
                color90: b.color([1.0, 1.0, 1.0]),
                exponent: b.float(5.0),
                roughness: rough,
                scatter_mode: ScatterMode::T,
                thin_film,
            },
            3 => LobeKind::Phong {
                color: b.color([0.9, 0.7, 0.5]),
                exponent: b.float(30.0),
            },
            _ => LobeKind::Blinn {
                color: b.color([0.9, 0.7, 0.5]),
                exponent: b.float(30.0),
                rolloff: b.float(0.4),
            },
        };
        let n = b.stream(Stream::N);
        let wo = b.normalize(n);
        let i = b.stream(Stream::I);
        let wi = b.normalize(i);
        let p = b.stream(Stream::P);
        let p = b.unary(UnOp::Abs, p);
        let u = b.unary(UnOp::Fract, p);
        let z = b.extract(wo, 2);
        let zero = b.float(0.0);
        let inside = b.binary(BinOp::Lt, z, zero);
        let e = kind.eval_sided(&mut b, inside, wo, wi);
        let s = kind.sample_sided(&mut b, inside, wo, u);
        let a = kind.albedo_sided(&mut b, inside, wo);
        b.output("value", None, e.value);
        b.output("pdf", None, e.pdf);
        b.output("wi", None, s.wi);
        b.output("weight", None, s.weight);
        b.output("spdf", None, s.pdf);
        b.output("albedo", None, a);
        let prog = b.finish().expect("lobe program");
        check_program(name, &prog, &env, u32::MAX, &frags, Class::Mixed);
    }
}

// ---- loops ----

/// The CPU back ends: the GPU runs loops but does not count their stops
/// (`Material::loop_limits`), and lavapipe caps a shader's loop iterations one short of the
/// nest's budget (docs/gpu.md, "Loops"); its loop rows are in `gpu/tests/backend.rs`.
fn cpu_only(ut: &UnderTest) -> bool {
    ut.name != "gpu"
}

/// A program over [`INPUTS`] with `body` and one output per label.
fn program_with_outputs(body: &str, outs: &[&str]) -> Program {
    let outputs: Vec<String> = outs
        .iter()
        .enumerate()
        .map(|(k, l)| format!("  output o{k} {l}\n"))
        .collect();
    let text = format!(
        "program \"row\" {{\n{INPUTS}\n{body}\n{}}}\n",
        outputs.concat()
    );
    parse(&text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// Loops (`Op::Loop`) against the interpreter, on every CPU back end and drive, outputs,
/// non-finite counts and loops stopped at the iteration limit alike: constant and varying
/// trip counts (lanes of a packet leaving at different iterations, some at the limit),
/// nested loops, conditionals inside a loop and loops inside a conditional and a light
/// loop, loops that never iterate, every carried type, and loops that never end.
#[test]
fn loops() {
    let frags = hard_fragments();
    let env = env();
    let rows: &[(&str, &str, Class)] = &[
        (
            "loop, counted",
            "  %i0 = const 0 : int\n  %s0 = const 0.0 : float\n  %l = loop %i0, %s0 while {\n    %ci = loop.var 0 : int\n    %ten = const 10 : int\n    %cc = lt %ci, %ten : bool\n    yield %cc\n  } do {\n    %bi = loop.var 0 : int\n    %bs = loop.var 1 : float\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    %fi = convert %bi : float\n    %t = mul %fi, %a : float\n    %t2 = add %t, %b : float\n    %bs1 = add %bs, %t2 : float\n    yield %bi1, %bs1\n  }\n  %x = proj %l, 1 : float",
            Class::Exact,
        ),
        (
            "loop, varying trip count",
            "  %x0 = const 0.0 : float\n  %n0 = const 0 : int\n  %l = loop %x0, %n0 while {\n    %cx = loop.var 0 : float\n    %twenty = const 20.0 : float\n    %lim = mul %b, %twenty : float\n    %cc = lt %cx, %lim : bool\n    yield %cc\n  } do {\n    %bx = loop.var 0 : float\n    %bn = loop.var 1 : int\n    %one = const 1.0 : float\n    %ab = abs %a : float\n    %st = add %one, %ab : float\n    %bx1 = add %bx, %st : float\n    %ione = const 1 : int\n    %bn1 = add %bn, %ione : int\n    yield %bx1, %bn1\n  }\n  %lx = proj %l, 0 : float\n  %ln = proj %l, 1 : int\n  %lnf = convert %ln : float\n  %x = construct %lx, %lnf : vec2",
            Class::Exact,
        ),
        (
            "loop, nested (the inner trip count depends on the outer carried value)",
            "  %o0 = const 0 : int\n  %c0 = const (0.0, 0.0, 0.0) : color\n  %lo = loop %o0, %c0 while {\n    %oi = loop.var 0 : int\n    %four = const 4 : int\n    %oc = lt %oi, %four : bool\n    yield %oc\n  } do {\n    %oi2 = loop.var 0 : int\n    %oacc = loop.var 1 : color\n    %j0 = const 0 : int\n    %li = loop %j0, %oacc while {\n      %ij = loop.var 0 : int\n      %qi = convert %q : int\n      %lim2 = add %oi2, %qi : int\n      %ic = lt %ij, %lim2 : bool\n      yield %ic\n    } do {\n      %ij2 = loop.var 0 : int\n      %iacc = loop.var 1 : color\n      %half = const 0.5 : float\n      %hs = splat %half : color\n      %sc = mul %iacc, %hs : color\n      %jf = convert %ij2 : float\n      %js = splat %jf : color\n      %pj = mul %pc, %js : color\n      %na = add %sc, %pj : color\n      %ione = const 1 : int\n      %ij3 = add %ij2, %ione : int\n      yield %ij3, %na\n    }\n    %inner = proj %li, 1 : color\n    %oone = const 1 : int\n    %oi3 = add %oi2, %oone : int\n    yield %oi3, %inner\n  }\n  %x = proj %lo, 1 : color",
            Class::Exact,
        ),
        (
            "loop, if inside the body",
            "  %i0 = const 0 : int\n  %v0 = const (0.0, 0.0, 0.0) : vec3\n  %l = loop %i0, %v0 while {\n    %ci = loop.var 0 : int\n    %sev = const 7 : int\n    %lim = mod %m, %sev : int\n    %cc = lt %ci, %lim : bool\n    yield %cc\n  } do {\n    %bi = loop.var 0 : int\n    %bv = loop.var 1 : vec3\n    %two = const 2 : int\n    %par = mod %bi, %two : int\n    %zero = const 0 : int\n    %even = eq %par, %zero : bool\n    %e = and %even, %q : bool\n    %r0 = if %e {\n      %t = add %bv, %p : vec3\n      yield %t\n    } else {\n      %u = cross %bv, %n : vec3\n      %u2 = sub %u, %n : vec3\n      yield %u2\n    }\n    %nv = proj %r0, 0 : vec3\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    yield %bi1, %nv\n  }\n  %x = proj %l, 1 : vec3",
            Class::Exact,
        ),
        (
            "loop inside an if arm",
            "  %x0 = if %q {\n    %i0 = const 0 : int\n    %l = loop %i0, %a while {\n      %ci = loop.var 0 : int\n      %five = const 5 : int\n      %lim = mod %m, %five : int\n      %cc = lt %ci, %lim : bool\n      yield %cc\n    } do {\n      %bi = loop.var 0 : int\n      %bs = loop.var 1 : float\n      %one = const 1 : int\n      %bi1 = add %bi, %one : int\n      %t = mul %bs, %a : float\n      %t2 = add %t, %b : float\n      yield %bi1, %t2\n    }\n    %y = proj %l, 1 : float\n    yield %y\n  } else {\n    yield %b\n  }\n  %x = proj %x0, 0 : float",
            Class::Exact,
        ),
        (
            "loop inside a light loop",
            "  %l0 = illuminance %p {\n    %L = light.L : vec3\n    %C = light.Cl : color\n    %d = dot %n, %L : float\n    %s0 = const 0.0 : float\n    %w0 = abs %d : float\n    %lp = loop %s0, %w0 while {\n      %lw = loop.var 1 : float\n      %eps = const 0.01 : float\n      %gc = gt %lw, %eps : bool\n      yield %gc\n    } do {\n      %ls = loop.var 0 : float\n      %lw2 = loop.var 1 : float\n      %lsn = add %ls, %lw2 : float\n      %hf = const 0.5 : float\n      %lwn = mul %lw2, %hf : float\n      yield %lsn, %lwn\n    }\n    %ss = proj %lp, 0 : float\n    %sc = splat %ss : color\n    %y = mul %C, %sc : color\n    yield %y\n  }\n  %x = proj %l0, 0 : color",
            Class::Intrinsic,
        ),
        (
            "loop, no iteration",
            "  %l = loop %a, %p while {\n    %za = loop.var 0 : float\n    %zc = lt %za, %za : bool\n    yield %zc\n  } do {\n    %zb = loop.var 0 : float\n    %zp = loop.var 1 : vec3\n    %z2 = add %zb, %zb : float\n    %zq = add %zp, %n : vec3\n    yield %z2, %zq\n  }\n  %l2 = loop while {\n    %f = const false : bool\n    yield %f\n  } do {\n    yield\n  }\n  %x1 = proj %l, 0 : float\n  %xv = proj %l, 1 : vec3\n  %x2 = extract %xv, 1 : float\n  %x = add %x1, %x2 : float",
            Class::Exact,
        ),
        (
            "loop that never ends, inside a loop of varying trip count (lanes that left the outer loop are not counted)",
            "  %i0 = const 0 : int\n  %z = const 0.0 : float\n  %l = loop %i0, %z while {\n    %ci = loop.var 0 : int\n    %four = const 4 : int\n    %lim = mod %m, %four : int\n    %cc = lt %ci, %lim : bool\n    yield %cc\n  } do {\n    %bi = loop.var 0 : int\n    %bs = loop.var 1 : float\n    %li = loop %bs while {\n      %t = const true : bool\n      yield %t\n    } do {\n      %v = loop.var 0 : float\n      %v1 = add %v, %a : float\n      yield %v1\n    }\n    %iv = proj %li, 0 : float\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    yield %bi1, %iv\n  }\n  %x = proj %l, 1 : float",
            Class::Exact,
        ),
        (
            "loop that never ends, inside an if arm (lanes of the other arm are not counted)",
            "  %x0 = if %q {\n    %l = loop %a while {\n      %t = const true : bool\n      yield %t\n    } do {\n      %bs = loop.var 0 : float\n      %bs1 = add %bs, %b : float\n      yield %bs1\n    }\n    %y = proj %l, 0 : float\n    yield %y\n  } else {\n    yield %b\n  }\n  %x = proj %x0, 0 : float",
            Class::Exact,
        ),
    ];
    for (name, body, class) in rows {
        let p = program(body);
        check_program_on(name, &p, &env, u32::MAX, &frags, class.clone(), &cpu_only);
        // Optimized too: loop-invariant values hoisted out, CSE and dead code inside.
        let (o, _) = opt::run(&p, &Specialization::default());
        let what = format!("{name} (optimized)");
        check_program_on(&what, &o, &env, u32::MAX, &frags, class.clone(), &cpu_only);
    }
    // Every carried type at once; the bool flips each turn, the int wraps.
    let body = "  %i0 = const 0 : int\n  %l = loop %i0, %p, %pc, %k, %q, %uv, %p4, %pc4 while {\n    %ci = loop.var 0 : int\n    %cb = loop.var 4 : bool\n    %three = const 3 : int\n    %lt3 = lt %ci, %three : bool\n    %six = const 6 : int\n    %lt6 = lt %ci, %six : bool\n    %more = and %lt6, %cb : bool\n    %cc = or %lt3, %more : bool\n    yield %cc\n  } do {\n    %bi = loop.var 0 : int\n    %bv = loop.var 1 : vec3\n    %bc = loop.var 2 : color\n    %bk = loop.var 3 : int\n    %bq = loop.var 4 : bool\n    %bu = loop.var 5 : vec2\n    %b4 = loop.var 6 : vec4\n    %bc4 = loop.var 7 : color4\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    %bv1 = mul %bv, %n : vec3\n    %bc1 = sub %bc, %nc : color\n    %kk = const 3 : int\n    %bk0 = mul %bk, %kk : int\n    %bk1 = add %bk0, %one : int\n    %bq1 = not %bq : bool\n    %bu1 = add %bu, %ba : vec2\n    %b41 = mul %b4, %n4 : vec4\n    %bc41 = add %bc4, %nc4 : color4\n    yield %bi1, %bv1, %bc1, %bk1, %bq1, %bu1, %b41, %bc41\n  }\n  %r0 = proj %l, 0 : int\n  %r1 = proj %l, 1 : vec3\n  %r2 = proj %l, 2 : color\n  %r3 = proj %l, 3 : int\n  %r4 = proj %l, 4 : bool\n  %r5 = proj %l, 5 : vec2\n  %r6 = proj %l, 6 : vec4\n  %r7 = proj %l, 7 : color4";
    let outs = ["%r0", "%r1", "%r2", "%r3", "%r4", "%r5", "%r6", "%r7"];
    let p = program_with_outputs(body, &outs);
    check_program_on(
        "loop, every carried type",
        &p,
        &env,
        u32::MAX,
        &frags,
        Class::Exact,
        &cpu_only,
    );
}

/// Loops that never end stop once their loop nest has run `LOOP_ITERATION_LIMIT` bodies, with
/// the values they have, and every back end and entry counts one stop per loop execution and fragment
/// (`Material::loop_limits`), padding lanes of a short packet not counted.
#[test]
fn loops_stop_at_the_iteration_limit_and_are_counted() {
    use shadenet_graph::ir::LOOP_ITERATION_LIMIT;
    // Seven fragments (a full packet and a short one), one of them with P.x NaN.
    let mut frags: Vec<Fragment> = hard_fragments().into_iter().take(7).collect();
    frags[5].p[0] = f32::NAN;
    let env = env();
    let limit = LOOP_ITERATION_LIMIT as f32;
    // (name, body, the output float per fragment, stops per fragment).
    type Expect = fn(&Fragment) -> (f32, u64);
    let rows: &[(&str, &str, Expect)] = &[
        (
            "always true",
            "  %z = const 0.0 : float\n  %l = loop %z while {\n    %t = const true : bool\n    yield %t\n  } do {\n    %v = loop.var 0 : float\n    %one = const 1.0 : float\n    %v1 = add %v, %one : float\n    yield %v1\n  }\n  %x = proj %l, 0 : float",
            |_| (LOOP_ITERATION_LIMIT as f32, 1),
        ),
        (
            "true where P.x is a number",
            "  %z = const 0.0 : float\n  %l = loop %z while {\n    %t = eq %a, %a : bool\n    yield %t\n  } do {\n    %v = loop.var 0 : float\n    %one = const 1.0 : float\n    %v1 = add %v, %one : float\n    yield %v1\n  }\n  %x = proj %l, 0 : float",
            |f| match f.p[0].is_nan() {
                true => (0.0, 0),
                false => (LOOP_ITERATION_LIMIT as f32, 1),
            },
        ),
        (
            "an endless loop inside a loop of three: the nest's budget",
            "  %z = const 0.0 : float\n  %o = const 0 : int\n  %l = loop %o, %z while {\n    %oi = loop.var 0 : int\n    %three = const 3 : int\n    %oc = lt %oi, %three : bool\n    yield %oc\n  } do {\n    %oi2 = loop.var 0 : int\n    %ov = loop.var 1 : float\n    %li = loop %ov while {\n      %t = const true : bool\n      yield %t\n    } do {\n      %v = loop.var 0 : float\n      %one = const 1.0 : float\n      %v1 = add %v, %one : float\n      yield %v1\n    }\n    %iv = proj %li, 0 : float\n    %ione = const 1 : int\n    %oi3 = add %oi2, %ione : int\n    yield %oi3, %iv\n  }\n  %x = proj %l, 1 : float",
            // The outer body's first run takes one iteration of the nest's budget, the inner
            // loop the rest (stopped: 1); the outer loop then has none left (stopped: 2).
            |_| (LOOP_ITERATION_LIMIT as f32 - 1.0, 2),
        ),
    ];
    let entries = |scalar, batch| {
        JitBackend::with_options(JitOptions {
            scalar,
            batch,
            fallback: false,
            ..JitOptions::default()
        })
    };
    let cases: Vec<(&str, Box<dyn Backend>, Drive)> = vec![
        ("interp", Box::new(InterpBackend), Drive::Scalar),
        ("interp-batch", Box::new(InterpBackend), Drive::Batch),
        ("jit-scalar", Box::new(entries(true, true)), Drive::Scalar),
        ("jit-batch", Box::new(entries(true, true)), Drive::Batch),
        ("jit-many", Box::new(entries(true, true)), Drive::Many),
        // `shade` through the batch entry, `shade_x4` through the scalar one.
        (
            "jit-batch-only",
            Box::new(entries(false, true)),
            Drive::Scalar,
        ),
        (
            "jit-scalar-only",
            Box::new(entries(true, false)),
            Drive::Batch,
        ),
    ];
    for (name, body, expect) in rows {
        let p = program(body);
        let want: Vec<(f32, u64)> = frags.iter().map(expect).collect();
        let stops: u64 = want.iter().map(|w| w.1).sum();
        for (label, backend, drive) in &cases {
            let m = backend.compile_program(&p, Duration::ZERO).unwrap();
            assert!(m.info().fallback.is_none(), "{label}: fell back");
            assert_eq!(m.loop_limits(), 0, "{name}: {label}: before shading");
            let (got, bad) = shade_all(&*m, *drive, &env, u32::MAX, &frags);
            let got_bits: Vec<u32> = got.iter().map(|x| x.to_bits()).collect();
            let want_bits: Vec<u32> = want.iter().map(|w| w.0.to_bits()).collect();
            assert_eq!(got_bits, want_bits, "{name}: {label}: values");
            assert_eq!(bad, 0, "{name}: {label}: non-finite");
            assert_eq!(m.loop_limits(), stops, "{name}: {label}: stops");
            // The count is a running total: a second pass doubles it.
            shade_all(&*m, *drive, &env, u32::MAX, &frags);
            assert_eq!(m.loop_limits(), 2 * stops, "{name}: {label}: second pass");
        }
    }
    assert_eq!(limit, 65536.0);
}

/// A loop compiles to one CLIF loop whatever its trip count: the same instructions and code
/// bytes for 10 and 4000 iterations, in both entries (the JIT never unrolls; the optimizer
/// may, but `compile_program` compiles the program as it is).
#[test]
fn loops_compile_once_whatever_the_trip_count() {
    let body = |trips: i32| {
        format!(
            "  %i0 = const 0 : int\n  %l = loop %i0, %p while {{\n    %ci = loop.var 0 : int\n    %nt = const {trips} : int\n    %cc = lt %ci, %nt : bool\n    yield %cc\n  }} do {{\n    %bi = loop.var 0 : int\n    %bv = loop.var 1 : vec3\n    %one = const 1 : int\n    %bi1 = add %bi, %one : int\n    %w = cross %bv, %n : vec3\n    %w2 = normalize %w : vec3\n    %bv1 = add %bv, %w2 : vec3\n    yield %bi1, %bv1\n  }}\n  %x = proj %l, 1 : vec3"
        )
    };
    for (scalar, batch) in [(true, false), (false, true)] {
        let jit = JitBackend::with_options(JitOptions {
            scalar,
            batch,
            fallback: false,
            ..JitOptions::default()
        });
        let stats = |trips| {
            let m = jit
                .compile_program(&program(&body(trips)), Duration::ZERO)
                .unwrap();
            let s = m.info().stats;
            eprintln!(
                "scalar {scalar} batch {batch}, {trips} trips: {} CLIF instructions, {} code bytes, lower {:?}, codegen {:?}",
                s.ir_insts, s.code_bytes, s.lower, s.codegen
            );
            (s.ir_insts, s.code_bytes)
        };
        let (short, long) = (stats(10), stats(4000));
        assert_eq!(short, long, "scalar {scalar} batch {batch}");
        assert!(short.0 < 400, "{short:?}: the body appears more than once?");
    }
}

/// Loops that ask the scene (a traced ray and a light loop reading `light.visible` in the
/// body, the direction carried from turn to turn, a trip count varying per lane): every CPU
/// back end and entry as the interpreter, with the scene where the entry has it.
#[test]
fn loops_ask_the_scene_as_the_interpreter() {
    let text = r#"program "loop scene" {
  %p = stream P : vec3
  %n = stream N : vec3
  %i = stream I : vec3
  %x = extract %p, 0 : float
  %zero = const 0.0 : float
  %pos = gt %x, %zero : bool
  %three = const 3 : int
  %one = const 1 : int
  %lim = select %pos, %three, %one : int
  %z = const (0.0, 0.0, 0.0) : color
  %i0 = const 0 : int
  %l = loop %i0, %z, %i while {
    %ci = loop.var 0 : int
    %cc = lt %ci, %lim : bool
    yield %cc
  } do {
    %bi = loop.var 0 : int
    %acc = loop.var 1 : color
    %d = loop.var 2 : vec3
    %t = trace reflection %d : color
    %lt = illuminance %p {
      %v = light.visible : float
      %c = light.Cl : color
      %vs = splat %v : color
      %s = mul %c, %vs : color
      yield %s
    }
    %lc = proj %lt, 0 : color
    %a1 = add %acc, %t : color
    %a2 = add %a1, %lc : color
    %d2 = add %d, %n : vec3
    %d3 = normalize %d2 : vec3
    %bi1 = add %bi, %one : int
    yield %bi1, %a2, %d3
  }
  %r = proj %l, 1 : color
  %cnt = proj %l, 0 : int
  output r %r
  output c %cnt
}
"#;
    let p = parse(text).unwrap();
    let frags = scene_fragments();
    let env = scene_env();
    assert!(
        check_scene_on("loop scene", &p, &env, &frags, &Class::Intrinsic, &cpu_only),
        "the scene changes nothing"
    );
}
