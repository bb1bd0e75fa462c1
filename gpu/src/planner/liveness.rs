//! Liveness: which step computes each value, which values each step reads, and the
//! `sn_tmp` columns of the values that cross a step boundary.
//!
//! Owns: the definitions and uses per step (and the extra last pass that writes outputs no
//! pass computes), the live ranges and their first-fit columns (a column is reused once the
//! live range of its occupant ends), and the finished [`Step`]s with their loads, stores,
//! outputs and shared guard. Must not touch: the cut into steps ([`super::partition`]) or
//! the kernels' text ([`crate::kernel`]).

use super::partition::RawStep;
use crate::emit;
use crate::plan::{Guard, HostKind, HostStep, ItemKind, Pass, Step, is_remat, value_name};
use shadenet_graph::ir::{Block, Op, Program, Value};
use shadenet_runtime::BackendError;
use std::collections::{BTreeSet, HashMap};

/// Values read by `block` (operands, conditions, yields, at any depth) that it does not
/// define itself.
fn free_values(p: &Program, block: &Block) -> BTreeSet<Value> {
    let mut defined = BTreeSet::new();
    p.walk(block, &mut |v| {
        defined.insert(v);
    });
    let mut used = BTreeSet::new();
    fn uses(p: &Program, b: &Block, used: &mut BTreeSet<Value>) {
        for &v in &b.body {
            p.op(v).for_each_operand(|a| {
                used.insert(a);
            });
            for inner in p.op(v).blocks() {
                uses(p, inner, used);
            }
        }
        used.extend(b.yields.iter().copied());
    }
    uses(p, block, &mut used);
    used.retain(|v| !defined.contains(v));
    used
}

/// Which step computes each value and which values each step reads.
pub(super) struct Flow {
    /// The step that computes each value (by arena index), for values a step computes.
    pub def: Vec<Option<usize>>,
    /// Per step: the values it reads that a step computes (operands, guard conditions, the
    /// last pass's late outputs).
    pub uses: Vec<BTreeSet<Value>>,
    /// Outputs no pass computes (indices into `Program::outputs`): constants, uniforms,
    /// streams, host results; the last pass writes them, after every host step.
    pub late_outputs: Vec<usize>,
}

/// The definitions and uses of every step of `raw`; appends an empty last pass when outputs
/// no pass computes need one to write them. `prelude` holds the uniform slot of each prelude
/// value, `projs` the `proj` users of each region.
pub(super) fn flow(
    p: &Program,
    raw: &mut Vec<RawStep>,
    prelude: &HashMap<usize, usize>,
    projs: &HashMap<usize, Vec<(Value, u8)>>,
) -> Flow {
    let n_values = p.exprs.len();
    let mut def: Vec<Option<usize>> = vec![None; n_values];
    let mut uses: Vec<BTreeSet<Value>> = Vec::new();
    let remat = |v: Value| is_remat(p, prelude, v);
    for (s, st) in raw.iter().enumerate() {
        let mut u = BTreeSet::new();
        match st {
            RawStep::Pass(items) => {
                for it in items {
                    for &(c, _) in &it.guard {
                        u.insert(c);
                    }
                    match &it.kind {
                        ItemKind::Value(v) => {
                            p.op(*v).for_each_operand(|a| {
                                u.insert(a);
                            });
                            def[v.index()] = Some(s);
                        }
                        ItemKind::Merge(r) => {
                            if let Op::If { cond, then_, else_ } = p.op(*r) {
                                u.insert(*cond);
                                for &(pv, k) in projs.get(&r.index()).into_iter().flatten() {
                                    if let (Some(t), Some(e)) =
                                        (then_.yields.get(k as usize), else_.yields.get(k as usize))
                                    {
                                        u.insert(*t);
                                        u.insert(*e);
                                    }
                                    def[pv.index()] = Some(s);
                                }
                            }
                        }
                        ItemKind::Loop { region } => {
                            if let Op::Loop { init, cond, body } = p.op(*region) {
                                u.extend(init.iter().copied());
                                for b in [cond, body] {
                                    u.extend(free_values(p, b));
                                    p.walk(b, &mut |x| def[x.index()] = Some(s));
                                }
                            }
                            for &(pv, _) in projs.get(&region.index()).into_iter().flatten() {
                                def[pv.index()] = Some(s);
                            }
                        }
                        ItemKind::Illuminance { region, .. } => {
                            if let Op::Illuminance { body, .. } = p.op(*region) {
                                u.extend(free_values(p, body));
                                p.walk(body, &mut |b| def[b.index()] = Some(s));
                            }
                            for &(pv, _) in projs.get(&region.index()).into_iter().flatten() {
                                def[pv.index()] = Some(s);
                            }
                        }
                    }
                }
            }
            RawStep::Host(h, g) => {
                for &(c, _) in g {
                    u.insert(c);
                }
                match h {
                    HostKind::Trace(v) | HostKind::Occlusion(v) => {
                        p.op(*v).for_each_operand(|a| {
                            u.insert(a);
                        });
                        def[v.index()] = Some(s);
                    }
                    HostKind::LightSamples { region, .. } => {
                        if let Op::Illuminance { p: point, .. } = p.op(*region) {
                            u.insert(*point);
                        }
                    }
                }
            }
        }
        u.retain(|v| !remat(*v));
        uses.push(u);
    }
    // Outputs not computed by a pass (constants, uniforms, streams, host results) are
    // written by the last pass, after every host step.
    let needs_out_pass = p
        .outputs
        .iter()
        .any(|o| def[o.value.index()].is_none_or(|s| matches!(raw[s], RawStep::Host(..))));
    if needs_out_pass && !matches!(raw.last(), Some(RawStep::Pass(_))) {
        raw.push(RawStep::Pass(Vec::new()));
        uses.push(BTreeSet::new());
    }
    let last = raw.len().saturating_sub(1);
    let mut late_outputs = Vec::new();
    for (k, o) in p.outputs.iter().enumerate() {
        match def[o.value.index()] {
            Some(s) if matches!(raw[s], RawStep::Pass(_)) => {}
            _ => {
                late_outputs.push(k);
                if !remat(o.value) {
                    uses[last].insert(o.value);
                }
            }
        }
    }
    Flow {
        def,
        uses,
        late_outputs,
    }
}

/// The `sn_tmp` columns of the values that cross a step boundary.
pub(super) struct TmpColumns {
    /// First column of each crossing value, by arena index.
    pub tmp: Vec<Option<usize>>,
    /// Columns of `sn_tmp`.
    pub columns: usize,
    /// Columns without reuse (the sum of the crossing values' widths).
    pub no_reuse: usize,
}

/// The live range of every value that crosses a step boundary and its `sn_tmp` columns,
/// first fit. A step that reads a value no earlier step computes is a
/// [`BackendError::Codegen`] (a planner bug); `names` is the printer's numbering.
pub(super) fn tmp_columns(
    p: &Program,
    names: &[Option<u32>],
    raw: &[RawStep],
    flow: &Flow,
) -> Result<TmpColumns, BackendError> {
    let n_values = p.exprs.len();
    let Flow { def, uses, .. } = flow;
    let mut last_use: Vec<Option<usize>> = vec![None; n_values];
    for (s, u) in uses.iter().enumerate() {
        for v in u {
            let d = def[v.index()];
            match d {
                Some(d) if d < s => {
                    let l = &mut last_use[v.index()];
                    *l = Some(l.map_or(s, |x: usize| x.max(s)));
                }
                Some(d) if d == s && matches!(raw[s], RawStep::Pass(_)) => {}
                _ => {
                    return Err(BackendError::Codegen {
                        backend: "gpu",
                        material: p.name.clone(),
                        message: format!(
                            "step {s} uses {} ({}) before any step computes it",
                            value_name(names, *v),
                            p.op(*v).short_name()
                        ),
                    });
                }
            }
        }
    }
    let mut crossing: Vec<Value> = (0..n_values)
        .filter(|&i| last_use[i].is_some())
        .map(Value::new)
        .collect();
    crossing.sort_by_key(|v| (def[v.index()], *v));
    let mut tmp: Vec<Option<usize>> = vec![None; n_values];
    let mut busy: Vec<usize> = Vec::new(); // per column: the step of its occupant's last use
    let mut no_reuse = 0;
    for v in &crossing {
        let w = emit::columns(p.ty(*v));
        no_reuse += w;
        let d = def[v.index()].unwrap_or(0);
        let free = |c: usize, busy: &[usize]| busy.get(c).is_none_or(|&b| b <= d);
        let mut c = 0;
        while !(c..c + w).all(|k| free(k, &busy)) {
            c += 1;
        }
        if busy.len() < c + w {
            busy.resize(c + w, 0);
        }
        let end = last_use[v.index()].unwrap_or(d);
        for b in &mut busy[c..c + w] {
            *b = end;
        }
        tmp[v.index()] = Some(c);
    }
    Ok(TmpColumns {
        tmp,
        columns: busy.len(),
        no_reuse,
    })
}

/// The finished steps: each host step with the values it reads back, each pass with its
/// loads, stores, outputs and the guard all its items share (none for a last pass that
/// writes late outputs). Kernels are written later.
pub(super) fn steps(
    p: &Program,
    raw: Vec<RawStep>,
    flow: &Flow,
    tmp: &[Option<usize>],
) -> Vec<Step> {
    let Flow {
        def,
        uses,
        late_outputs,
    } = flow;
    let last = raw.len().saturating_sub(1);
    let mut steps = Vec::new();
    for (s, st) in raw.into_iter().enumerate() {
        let mut loads: Vec<Value> = uses[s]
            .iter()
            .copied()
            .filter(|v| def[v.index()] != Some(s))
            .collect();
        loads.sort();
        match st {
            RawStep::Host(kind, guard) => steps.push(Step::Host(HostStep {
                kind,
                guard,
                reads: loads,
            })),
            RawStep::Pass(items) => {
                let mut stores = Vec::new();
                let mut outs = Vec::new();
                for (i, d) in def.iter().enumerate() {
                    if *d == Some(s) && tmp[i].is_some() {
                        stores.push(Value::new(i));
                    }
                }
                for (k, o) in p.outputs.iter().enumerate() {
                    if def[o.value.index()] == Some(s) || (s == last && late_outputs.contains(&k)) {
                        outs.push(k);
                    }
                }
                let mut guard: Guard = items.first().map(|i| i.guard.clone()).unwrap_or_default();
                for it in &items {
                    let common = guard
                        .iter()
                        .zip(&it.guard)
                        .take_while(|(a, b)| a == b)
                        .count();
                    guard.truncate(common);
                }
                if s == last && !late_outputs.is_empty() {
                    guard.clear();
                }
                let cost = items.iter().map(|i| i.cost).sum();
                let lights = items
                    .iter()
                    .any(|i| matches!(i.kind, ItemKind::Illuminance { .. }));
                steps.push(Step::Pass(Pass {
                    items,
                    guard,
                    loads,
                    stores,
                    outputs: outs,
                    cost,
                    lights,
                    textures: false,
                    tables: false,
                    wgsl: String::new(),
                }));
            }
        }
    }
    steps
}
