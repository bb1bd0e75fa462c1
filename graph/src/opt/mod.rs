//! Partial evaluation: a [`Specialization`] in, a faster [`Program`] and a [`Report`] out
//! (DESIGN §5).
//!
//! Each pass lives in its own file with one entry point, `run(&mut Program, &Specialization)
//! -> usize`, returning how many changes it made. [`run`] is the whole pipeline, in one
//! function:
//!
//! 1. [`specialize`] once: bake parameters into constants (instance compilation), turn
//!    `component_enabled(k)` into constants from the active mask, and ray-type tests into
//!    constants from the ray types the material will see;
//! 2. to a fixed point, at most `budget` rounds: [`fold`] (constants, exact identities),
//!    [`dead_branch`] (constant conditions), [`unroll`] (loops with a constant trip count,
//!    within a budget), [`cse`] (value numbering), [`dce`] (unused values);
//! 3. [`hoist`] once: move values that depend on parameters into the prelude (computed once
//!    per material instance), then, if it moved anything, `cse` (sibling arms may have
//!    computed the same uniform value) and `dce`; then compaction;
//! 4. [`needs`]: what the program still reads.
//!
//! Every pass keeps results bit-identical in f32, the shading precision: folding evaluates
//! with the interpreter's own f32 op semantics, and only identities that are exact in IEEE
//! arithmetic are applied (`x * 1`, `x - 0`, `x + (-0)`, `x / 1`; never float `x * 0` or
//! `x - x`).
//! f64 reference runs should use the unoptimized program.

pub mod cse;
pub mod dce;
pub mod dead_branch;
pub mod fold;
pub mod hoist;
pub mod needs;
pub mod specialize;
pub mod unroll;

pub use needs::Needs;

use crate::ir::{Program, RAY_CAMERA, RAY_DIFFUSE, RAY_REFLECTION, RAY_REFRACTION, RAY_SHADOW};
use std::time::{Duration, Instant};

/// Every ray type.
pub const ALL_RAY_TYPES: u32 =
    (RAY_CAMERA | RAY_SHADOW | RAY_REFLECTION | RAY_REFRACTION | RAY_DIFFUSE) as u32;

/// Which passes run (all by default; benchmarks switch CSE off to measure per-node cost).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Passes {
    /// Constant folding and exact identities.
    pub fold: bool,
    /// Component-mask and ray-type specialization.
    pub specialize: bool,
    /// Constant conditions pick their live arm.
    pub dead_branch: bool,
    /// Common subexpression elimination.
    pub cse: bool,
    /// Dead code elimination.
    pub dce: bool,
    /// Uniform hoisting into the prelude.
    pub hoist: bool,
    /// Loops with a constant trip count become copies of their body ([`unroll`]).
    pub unroll: bool,
}

impl Default for Passes {
    fn default() -> Self {
        Passes {
            fold: true,
            specialize: true,
            dead_branch: true,
            cse: true,
            dce: true,
            hoist: true,
            unroll: true,
        }
    }
}

impl Passes {
    /// No pass at all (the program is only compacted).
    pub const NONE: Passes = Passes {
        fold: false,
        specialize: false,
        dead_branch: false,
        cse: false,
        dce: false,
        hoist: false,
        unroll: false,
    };
}

/// What is fixed for one compile.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Specialization {
    /// Active render components: bit `i` is `Program::components[i]`.
    pub components: u32,
    /// The ray types the material will see (`RAY_*` bits).
    pub ray_types: u32,
    /// Instance compilation: parameters become constants (fastest). Without it (class
    /// compilation) parameters stay uniform and can change without recompiling.
    pub bake: bool,
    /// Which passes run.
    pub passes: Passes,
    /// At most this many fold/dead-branch/cse/dce rounds.
    pub budget: usize,
}

impl Default for Specialization {
    fn default() -> Self {
        Specialization {
            components: u32::MAX,
            ray_types: ALL_RAY_TYPES,
            bake: true,
            passes: Passes::default(),
            budget: 16,
        }
    }
}

impl Specialization {
    /// The active-component mask for a list of component names of `program`; `Err` names an
    /// unknown component and lists the known ones.
    pub fn mask_of(program: &Program, names: &[String]) -> Result<u32, String> {
        let mut mask = 0;
        for n in names {
            match program.component_index(n) {
                Some(k) => mask |= 1 << k,
                None => {
                    return Err(format!(
                        "`{n}` is not a component of this material (it has: {})",
                        if program.components.is_empty() {
                            "none".to_string()
                        } else {
                            program.components.join(", ")
                        }
                    ));
                }
            }
        }
        Ok(mask)
    }
}

/// What one pass did over the whole pipeline run (summed over rounds).
#[derive(Clone, Debug, PartialEq)]
pub struct PassStat {
    /// The pass's name.
    pub pass: &'static str,
    /// Ops before its first run.
    pub ops_before: usize,
    /// Ops after its last run.
    pub ops_after: usize,
    /// Changes it reported.
    pub changes: usize,
    /// Times it ran.
    pub runs: usize,
    /// Time spent in it.
    pub time: Duration,
}

/// Why the fixed-point loop stopped (egg's `StopReason`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// A round changed nothing.
    FixedPoint,
    /// The round budget ran out while passes still changed things.
    Budget,
}

/// What the optimizer did.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// Per pass, in first-run order.
    pub passes: Vec<PassStat>,
    /// Fixed-point rounds run.
    pub rounds: usize,
    /// Why the loop stopped.
    pub stop: StopReason,
    /// Ops before and after.
    pub ops_before: usize,
    /// Ops after the pipeline.
    pub ops_after: usize,
    /// What the optimized program reads.
    pub needs: Needs,
    /// Total time.
    pub time: Duration,
}

/// A pass entry point.
pub type PassFn = fn(&mut Program, &Specialization) -> usize;

/// Every pass by name (the names `--emit ir:after=NAME` and the filetests use).
pub const PASSES: &[(&str, PassFn)] = &[
    ("specialize", specialize::run),
    ("fold", fold::run),
    ("dead_branch", dead_branch::run),
    ("cse", cse::run),
    ("dce", dce::run),
    ("hoist", hoist::run),
    ("unroll", unroll::run),
];

/// The pass called `name`.
pub fn pass(name: &str) -> Option<PassFn> {
    PASSES.iter().find(|(n, _)| *n == name).map(|(_, f)| *f)
}

/// Runs the pipeline; see [`run_observed`].
pub fn run(program: &Program, spec: &Specialization) -> (Program, Report) {
    run_observed(program, spec, &mut |_, _| {})
}

/// Runs the whole pipeline on a copy of `program`, calling `observe(pass, program)` after
/// every pass run (for `--emit ir:after=PASS`).
pub fn run_observed(
    program: &Program,
    spec: &Specialization,
    observe: &mut dyn FnMut(&str, &Program),
) -> (Program, Report) {
    let start = Instant::now();
    let mut p = program.clone();
    let ops_before = p.op_count();
    let mut stats: Vec<PassStat> = Vec::new();
    let mut step = |name: &'static str, f: PassFn, p: &mut Program| -> usize {
        let before = p.op_count();
        let t = Instant::now();
        let changes = f(p, spec);
        let time = t.elapsed();
        let after = p.op_count();
        match stats.iter_mut().find(|s| s.pass == name) {
            Some(s) => {
                s.ops_after = after;
                s.changes += changes;
                s.runs += 1;
                s.time += time;
            }
            None => stats.push(PassStat {
                pass: name,
                ops_before: before,
                ops_after: after,
                changes,
                runs: 1,
                time,
            }),
        }
        observe(name, p);
        debug_assert!(
            crate::ir::validate(p).is_ok(),
            "pass {name} left an invalid program: {:?}\n{p}",
            crate::ir::validate(p)
        );
        changes
    };

    let ps = spec.passes;
    if ps.specialize || spec.bake {
        step("specialize", specialize::run, &mut p);
    }
    let mut rounds = 0;
    let mut stop = StopReason::FixedPoint;
    loop {
        if rounds == spec.budget {
            stop = StopReason::Budget;
            break;
        }
        rounds += 1;
        let mut changed = 0;
        if ps.fold {
            changed += step("fold", fold::run, &mut p);
        }
        if ps.dead_branch {
            changed += step("dead_branch", dead_branch::run, &mut p);
        }
        if ps.unroll {
            changed += step("unroll", unroll::run, &mut p);
        }
        if ps.cse {
            changed += step("cse", cse::run, &mut p);
        }
        if ps.dce {
            changed += step("dce", dce::run, &mut p);
        }
        if changed == 0 {
            break;
        }
    }
    if ps.hoist && step("hoist", hoist::run, &mut p) > 0 {
        // Hoisting can put equal values from sibling arms side by side in the prelude.
        if ps.cse {
            step("cse", cse::run, &mut p);
        }
        if ps.dce {
            step("dce", dce::run, &mut p);
        }
    }
    p.compact();
    let needs = needs::analyze(&p);
    let report = Report {
        passes: stats,
        rounds,
        stop,
        ops_before,
        ops_after: p.op_count(),
        needs,
        time: start.elapsed(),
    };
    (p, report)
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{:<12} {:>6} {:>6} {:>8} {:>5} {:>10}",
            "pass", "before", "after", "changes", "runs", "time"
        )?;
        for s in &self.passes {
            writeln!(
                f,
                "{:<12} {:>6} {:>6} {:>8} {:>5} {:>8.3}ms",
                s.pass,
                s.ops_before,
                s.ops_after,
                s.changes,
                s.runs,
                s.time.as_secs_f64() * 1e3
            )?;
        }
        writeln!(
            f,
            "total: {} → {} ops in {:.3} ms, {} rounds ({})",
            self.ops_before,
            self.ops_after,
            self.time.as_secs_f64() * 1e3,
            self.rounds,
            match self.stop {
                StopReason::FixedPoint => "fixed point",
                StopReason::Budget => "budget exhausted",
            }
        )?;
        write!(f, "{}", self.needs)
    }
}
