//! The planner: cuts one program into a [`Plan`] (docs/gpu.md, "Plan").
//!
//! Owns: the linearization of the program's top-level block into [`Item`]s, the
//! [`HostStep`]s that cut the sequence (`trace`, `occlusion`, light samples at a point other
//! than the stream `P`), the partitioning of the items between host steps into [`Pass`]es
//! (by op budget, fused, or a pass count), the live ranges of the values that cross a pass
//! or host-step boundary and their `sn_tmp` columns (first fit, columns reused once a live
//! range ends), the fixed buffer layouts, and the adapter limit checks.
//!
//! [`plan`] needs no device: it takes the adapter's [`wgpu::Limits`] (callers without a
//! device pass `wgpu::Limits::default()`), has every pass's WGSL kernel written
//! ([`crate::kernel`]) and validates it with naga, so an invalid kernel is a
//! [`BackendError::Codegen`] naming the material and the pass, never a wgpu panic.
//!
//! Must not touch: the plan's types and their printing ([`crate::plan`]), the text of a
//! kernel ([`crate::kernel`]), wgpu devices, buffers and dispatch ([`crate::material`]); the
//! WGSL form of pure ops ([`crate::emit`]).

use crate::emit;
use crate::kernel;
use crate::options::{GpuOptions, PassMode};
use crate::plan::{
    Guard, HostKind, HostStep, Item, ItemKind, Layout, LightSet, Pass, Plan, Step, U_VALUES,
    is_remat, value_name,
};
use shadenet_graph::ir::{Block, Op, Program, Stream, Value};
use shadenet_graph::opt::needs;
use shadenet_runtime::BackendError;
use shadenet_runtime::interp::output_layout;
use std::collections::{BTreeSet, HashMap};

/// The printer's numbering (`%N` in the IR text form): prelude then body, a region before
/// the values of its blocks.
fn number_values(p: &Program) -> Vec<Option<u32>> {
    fn go(p: &Program, b: &Block, names: &mut [Option<u32>], next: &mut u32) {
        for &v in &b.body {
            if let Some(slot @ None) = names.get_mut(v.index()) {
                *slot = Some(*next);
                *next += 1;
                for inner in p.op(v).blocks() {
                    go(p, inner, names, next);
                }
            }
        }
    }
    let mut names = vec![None; p.exprs.len()];
    let mut next = 0;
    go(p, &p.prelude, &mut names, &mut next);
    go(p, &p.body, &mut names, &mut next);
    names
}

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

/// One entry of the linear sequence before partitioning.
enum Entry {
    Item(Item),
    Host(HostKind, Guard),
}

struct Linearizer<'a> {
    p: &'a Program,
    prelude: &'a HashMap<usize, usize>,
    names: &'a [Option<u32>],
    entries: Vec<Entry>,
    sets: Vec<LightSet>,
    /// The set of light loops at the stream `P`, once one exists.
    set_p: Option<usize>,
}

fn unsupported(p: &Program, names: &[Option<u32>], v: Value, reason: String) -> BackendError {
    BackendError::Unsupported {
        backend: "gpu",
        material: p.name.clone(),
        op: format!("{} = {}", value_name(names, v), p.op(v).short_name()),
        reason,
    }
}

impl Linearizer<'_> {
    fn block(&mut self, block: &Block, guard: &Guard) -> Result<(), BackendError> {
        let p = self.p;
        for &v in &block.body {
            if is_remat(p, self.prelude, v) {
                continue;
            }
            match p.op(v) {
                Op::Proj(..) => {}
                Op::If { cond, then_, else_ } => {
                    let mut g = guard.clone();
                    g.push((*cond, true));
                    self.block(then_, &g)?;
                    g.pop();
                    g.push((*cond, false));
                    self.block(else_, &g)?;
                    let cost = then_.yields.len().max(1);
                    self.entries.push(Entry::Item(Item {
                        kind: ItemKind::Merge(v),
                        guard: guard.clone(),
                        cost,
                    }));
                }
                Op::Illuminance { p: point, body } => {
                    let mut cost = 0;
                    let mut bad = None;
                    p.walk(body, &mut |b| {
                        match p.op(b) {
                            Op::Trace { .. } | Op::Occlusion { .. } | Op::Illuminance { .. } => {
                                bad.get_or_insert(b);
                            }
                            _ => {}
                        }
                        if !is_remat(p, self.prelude, b) && !matches!(p.op(b), Op::Proj(..)) {
                            cost += 1;
                        }
                    });
                    if let Some(b) = bad {
                        return Err(unsupported(
                            p,
                            self.names,
                            b,
                            format!(
                                "inside the light loop {}: the GPU back end runs a light loop \
                                 whole in one kernel and cannot stop it for a host step",
                                value_name(self.names, v)
                            ),
                        ));
                    }
                    let reads_visible = {
                        let mut r = false;
                        p.walk(body, &mut |b| r |= *p.op(b) == Op::LightVisible);
                        r
                    };
                    let set = if *p.op(*point) == Op::Stream(Stream::P) {
                        match self.set_p {
                            Some(s) => {
                                self.sets[s].visible |= reads_visible;
                                s
                            }
                            None => {
                                self.sets.push(LightSet {
                                    point: None,
                                    visible: reads_visible,
                                });
                                self.set_p = Some(self.sets.len() - 1);
                                self.sets.len() - 1
                            }
                        }
                    } else {
                        self.sets.push(LightSet {
                            point: Some(*point),
                            visible: reads_visible,
                        });
                        let s = self.sets.len() - 1;
                        self.entries.push(Entry::Host(
                            HostKind::LightSamples { region: v, set: s },
                            guard.clone(),
                        ));
                        s
                    };
                    self.entries.push(Entry::Item(Item {
                        kind: ItemKind::Illuminance { region: v, set },
                        guard: guard.clone(),
                        cost: cost.max(1),
                    }));
                }
                Op::Trace { .. } => self
                    .entries
                    .push(Entry::Host(HostKind::Trace(v), guard.clone())),
                Op::Occlusion { .. } => self
                    .entries
                    .push(Entry::Host(HostKind::Occlusion(v), guard.clone())),
                _ => self.entries.push(Entry::Item(Item {
                    kind: ItemKind::Value(v),
                    guard: guard.clone(),
                    cost: 1,
                })),
            }
        }
        Ok(())
    }
}

/// Splits one run of items (between host steps) into passes.
fn partition(items: Vec<Item>, mode: PassMode, budget: usize, parts: usize) -> Vec<Vec<Item>> {
    if items.is_empty() {
        return Vec::new();
    }
    match mode {
        PassMode::Fused => vec![items],
        PassMode::Auto => {
            let budget = budget.max(1);
            let mut out: Vec<Vec<Item>> = Vec::new();
            let mut cur: Vec<Item> = Vec::new();
            let mut cost = 0;
            for it in items {
                if !cur.is_empty() && cost + it.cost > budget {
                    out.push(std::mem::take(&mut cur));
                    cost = 0;
                }
                cost += it.cost;
                cur.push(it);
            }
            out.push(cur);
            out
        }
        PassMode::Count(_) => {
            let parts = parts.clamp(1, items.len());
            let total: usize = items.iter().map(|i| i.cost).sum();
            let n = items.len();
            let mut out: Vec<Vec<Item>> = Vec::new();
            let mut cur: Vec<Item> = Vec::new();
            let mut cum = 0usize;
            for (k, it) in items.into_iter().enumerate() {
                cum += it.cost;
                cur.push(it);
                let done = out.len();
                let left_items = n - k - 1;
                let left_parts = parts - done - 1;
                if left_parts == 0 {
                    continue;
                }
                // Close this part when it reached its share, or when every remaining item
                // must start a part of its own.
                if cum * parts >= total * (done + 1) || left_items == left_parts {
                    out.push(std::mem::take(&mut cur));
                }
            }
            if !cur.is_empty() {
                out.push(cur);
            }
            out
        }
    }
}

/// How many of `n` passes each run of items gets: proportional to its cost, at least one
/// per non-empty run, at most one per item.
fn share_passes(costs: &[(usize, usize)], n: usize) -> Vec<usize> {
    let total: usize = costs.iter().map(|c| c.0).sum::<usize>().max(1);
    let mut k: Vec<usize> = costs
        .iter()
        .map(|&(c, items)| {
            if items == 0 {
                0
            } else {
                (c * n / total).clamp(1, items)
            }
        })
        .collect();
    // Too many (each run got at least one): take back from the runs with the least cost
    // per pass.
    while k.iter().sum::<usize>() > n {
        let cheapest = (0..costs.len())
            .filter(|&i| k[i] > 1)
            .min_by_key(|&i| (costs[i].0 * 1000) / k[i]);
        match cheapest {
            Some(i) => k[i] -= 1,
            None => break,
        }
    }
    // Hand out what is left to the runs with the most cost per pass.
    loop {
        let used: usize = k.iter().sum();
        if used >= n {
            break;
        }
        let best = (0..costs.len())
            .filter(|&i| k[i] < costs[i].1)
            .max_by_key(|&i| (costs[i].0 * 1000) / k[i].max(1));
        match best {
            Some(i) => k[i] += 1,
            None => break,
        }
    }
    k
}

/// Plans `program` (already specialized and optimized, or deliberately not) for the GPU
/// under the adapter's `limits` (pass `wgpu::Limits::default()` without a device): items,
/// host steps, passes, `sn_tmp` columns, every pass's WGSL kernel (validated with naga).
///
/// Errors: [`BackendError::Unsupported`] for a program this back end cannot run (a host step
/// inside a light loop, an op the WGSL emitter does not know, limits the adapter does not
/// meet) — the material falls back; [`BackendError::Codegen`] for a kernel naga rejects (a
/// back-end bug), naming the material and the pass.
pub fn plan(
    program: &Program,
    options: &GpuOptions,
    limits: &wgpu::Limits,
) -> Result<Plan, BackendError> {
    let p = program;
    shadenet_graph::ir::validate(p).map_err(|e| BackendError::Codegen {
        backend: "gpu",
        material: p.name.clone(),
        message: format!("the program is not valid: {e}"),
    })?;
    let names = number_values(p);
    let limit_err = |reason: String| BackendError::Unsupported {
        backend: "gpu",
        material: p.name.clone(),
        op: "the program".into(),
        reason,
    };
    if options.workgroup_size == 0
        || options.workgroup_size > limits.max_compute_invocations_per_workgroup
        || options.workgroup_size > limits.max_compute_workgroup_size_x
    {
        return Err(limit_err(format!(
            "workgroup size {} is outside what the adapter allows (1..={})",
            options.workgroup_size,
            limits
                .max_compute_invocations_per_workgroup
                .min(limits.max_compute_workgroup_size_x)
        )));
    }

    // ---- fixed layouts: fragment streams, outputs, uniforms ----
    let nd = needs::analyze(p);
    let mut streams = Vec::new();
    let mut frag_columns = 0;
    for s in Stream::ALL {
        if nd.streams.contains(&s) {
            streams.push((s, frag_columns));
            frag_columns += emit::columns(s.ty());
        }
    }
    let seed = frag_columns;
    frag_columns += 1;
    let (outputs, out_columns) = output_layout(p);
    let mut uniforms = U_VALUES;
    let mut prelude = HashMap::new();
    for &v in &p.prelude.body {
        if let Some(ty) = p.expr(v).ty {
            prelude.insert(v.index(), uniforms);
            uniforms += emit::columns(ty);
        }
    }
    let mut params = HashMap::new();
    for v in p.listed() {
        if let Op::Param(i) = p.op(v)
            && !prelude.contains_key(&v.index())
            && !params.contains_key(i)
            && let Some(d) = p.params.get(*i as usize)
        {
            params.insert(*i, uniforms);
            uniforms += emit::columns(d.ty);
        }
    }
    let mut projs: HashMap<usize, Vec<(Value, u8)>> = HashMap::new();
    for v in p.listed() {
        if let Op::Proj(r, k) = p.op(v) {
            projs.entry(r.index()).or_default().push((v, *k));
        }
    }

    // ---- items and host steps ----
    let mut lin = Linearizer {
        p,
        prelude: &prelude,
        names: &names,
        entries: Vec::new(),
        sets: Vec::new(),
        set_p: None,
    };
    lin.block(&p.body, &Vec::new())?;
    let Linearizer { entries, sets, .. } = lin;

    // Runs of items between host steps.
    let mut runs: Vec<Vec<Item>> = vec![Vec::new()];
    let mut hosts: Vec<(HostKind, Guard)> = Vec::new();
    for e in entries {
        match e {
            Entry::Item(it) => runs.last_mut().expect("a run").push(it),
            Entry::Host(h, g) => {
                hosts.push((h, g));
                runs.push(Vec::new());
            }
        }
    }
    let parts = match options.passes {
        PassMode::Count(n) => {
            let costs: Vec<(usize, usize)> = runs
                .iter()
                .map(|r| (r.iter().map(|i| i.cost).sum(), r.len()))
                .collect();
            share_passes(&costs, n as usize)
        }
        _ => vec![1; runs.len()],
    };
    let mut raw: Vec<RawStep> = Vec::new();
    let mut hosts = hosts.into_iter();
    for (k, run) in runs.into_iter().enumerate() {
        for items in partition(run, options.passes, options.op_budget, parts[k]) {
            raw.push(RawStep::Pass(items));
        }
        if let Some((h, g)) = hosts.next() {
            raw.push(RawStep::Host(h, g));
        }
    }

    // ---- definitions and uses per step ----
    let n_values = p.exprs.len();
    let mut def: Vec<Option<usize>> = vec![None; n_values];
    let mut uses: Vec<BTreeSet<Value>> = Vec::new();
    let remat = |v: Value| is_remat(p, &prelude, v);
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

    // ---- live ranges and tmp columns (first fit) ----
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
                            value_name(&names, *v),
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

    let layout = Layout {
        streams,
        seed,
        frag_columns,
        outputs,
        out_columns,
        prelude,
        params,
        uniforms,
        tmp,
        tmp_columns: busy.len(),
        tmp_columns_no_reuse: no_reuse,
        light_sets: sets,
        textures: false,
    };

    // ---- steps ----
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
                    if *d == Some(s) && layout.tmp[i].is_some() {
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
                    wgsl: String::new(),
                }));
            }
        }
    }

    // ---- limits ----
    let per_fragment = [frag_columns, out_columns, layout.tmp_columns]
        .into_iter()
        .max()
        .unwrap_or(1)
        .max(1) as u64;
    let binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let by_binding = binding / (4 * per_fragment);
    let by_dispatch =
        limits.max_compute_workgroups_per_dimension as u64 * options.workgroup_size as u64;
    let limit_batch = by_binding.min(by_dispatch).min(usize::MAX as u64) as usize;
    if limit_batch == 0 {
        return Err(limit_err(format!(
            "one fragment needs {} bytes in one buffer; the adapter binds at most {binding}",
            4 * per_fragment
        )));
    }

    let mut plan = Plan {
        material: p.name.clone(),
        steps,
        layout,
        options: options.clone(),
        limit_batch,
        binding_size: binding,
        buffers_per_stage: limits.max_storage_buffers_per_shader_stage,
        ops: p.op_count(),
        names,
        projs,
        def,
        widths: p
            .exprs
            .iter()
            .map(|e| e.ty.map_or(0, emit::columns))
            .collect(),
    };

    // ---- kernels ----
    let mut kernels = Vec::new();
    let mut pass_no = 0;
    for s in 0..plan.steps.len() {
        if let Step::Pass(_) = &plan.steps[s] {
            let k = kernel::write(p, &plan, s, pass_no)?;
            kernels.push((s, k));
            pass_no += 1;
        }
    }
    for (s, k) in kernels {
        if let Step::Pass(pass) = &mut plan.steps[s] {
            pass.textures = k.textures;
            pass.wgsl = k.wgsl;
            plan.layout.textures |= k.textures;
        }
    }
    let need = 4
        + u32::from(!plan.layout.light_sets.is_empty())
        + if plan.layout.textures { 2 } else { 0 };
    if need > limits.max_storage_buffers_per_shader_stage {
        return Err(limit_err(format!(
            "the kernels bind {need} storage buffers; the adapter allows {} per shader stage",
            limits.max_storage_buffers_per_shader_stage
        )));
    }
    for k in plan.kernels() {
        kernel::validate(k.wgsl).map_err(|message| BackendError::Codegen {
            backend: "gpu",
            material: p.name.clone(),
            message: format!("pass {}: naga rejects the kernel: {message}", k.pass),
        })?;
    }
    Ok(plan)
}

enum RawStep {
    Pass(Vec<Item>),
    Host(HostKind, Guard),
}
