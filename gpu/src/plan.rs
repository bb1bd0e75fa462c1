//! The pass plan: how one program runs as GPU passes and host steps (docs/gpu.md, "Plan").
//!
//! Owns: the linearization of the program's top-level block into [`Item`]s (values; an `If`
//! as its arms' items under a [`Guard`] and a merge; an `Illuminance` as one atomic item),
//! the [`HostStep`]s that cut the sequence (`trace`, `occlusion`, light samples at a point
//! other than the stream `P`), the partitioning of the items between host steps into
//! [`Pass`]es (by op budget, fused, or a pass count), the live ranges of the values that
//! cross a pass or host-step boundary and their `sn_tmp` columns (first fit, columns reused
//! once a live range ends), the buffer layouts every kernel and the host agree on
//! ([`Layout`]), the adapter limit checks, and `Plan: Display` (what `shadenet compile
//! --emit wgsl --stats` prints).
//!
//! [`plan`] needs no device: it takes the adapter's [`wgpu::Limits`] (callers without a
//! device pass `wgpu::Limits::default()`), writes every pass's WGSL kernel
//! ([`crate::kernel`]) and validates it with naga, so an invalid kernel is a
//! [`BackendError::Codegen`] naming the material and the pass, never a wgpu panic.
//!
//! Must not touch: wgpu devices, buffers and dispatch ([`crate::material`]); the WGSL form
//! of pure ops ([`crate::emit`]).

use crate::emit;
use crate::kernel;
use crate::material::{GpuOptions, PassMode};
use shadenet_graph::ir::{Block, Op, Program, Stream, Value};
use shadenet_graph::opt::needs;
use shadenet_graph::types::ConstValue;
use shadenet_runtime::BackendError;
use shadenet_runtime::interp::{OutputSlot, output_layout};
use std::collections::{BTreeSet, HashMap};
use std::fmt;

/// Uniform slot of the fragment count `n` (its bits, as `u32`).
pub const U_N: usize = 0;
/// Uniform slot of the component mask (bits).
pub const U_MASK: usize = 1;
/// Uniform slot of the light sample count `S` per fragment (bits, `u32`).
pub const U_SAMPLES: usize = 2;
/// First of three uniform slots holding the ambient light's color.
pub const U_AMBIENT: usize = 3;
/// Uniform slot holding 0 (as bits): the kernels' value barrier (see `crate::kernel`).
pub const U_KEEP: usize = 6;
/// First uniform slot of the world → camera matrix (16 floats, row-major).
pub const U_CAMERA: usize = 8;
/// First uniform slot of the camera → world matrix.
pub const U_CAMERA_INV: usize = 24;
/// First uniform slot of the world → object matrix.
pub const U_OBJECT: usize = 40;
/// First uniform slot of the object → world matrix.
pub const U_OBJECT_INV: usize = 56;
/// First uniform slot after the fixed ones: prelude values, then parameters.
pub const U_VALUES: usize = 72;
/// Columns of one light sample in `sn_light`: L (3), Cl (3), visible (1).
pub const LIGHT_COLUMNS: usize = 7;
/// Storage buffers a kernel may bind at most (uni, frag, out, tmp, light, texels, tex info).
pub const MAX_BINDINGS: u32 = 7;

/// The conditions an item runs under: each `(cond, polarity)` must hold (`cond == polarity`),
/// outermost first.
pub type Guard = Vec<(Value, bool)>;

/// What one item of the linearized program computes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ItemKind {
    /// One value (a pure op, a transform, a texture lookup).
    Value(Value),
    /// The results of an `If` whose arms ran as guarded items: each `proj` of the region is
    /// set to `select(else_yield, then_yield, cond)`.
    Merge(Value),
    /// A light loop, run whole in one kernel over the samples of light set `set`.
    Illuminance {
        /// The `Illuminance` value.
        region: Value,
        /// Index into [`Layout::light_sets`].
        set: usize,
    },
}

/// One item of a pass: what it computes, under which guard, at which cost.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Item {
    /// What it computes.
    pub kind: ItemKind,
    /// When it runs.
    pub guard: Guard,
    /// Its op count (the cost model's unit).
    pub cost: usize,
}

/// What a host step does.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HostKind {
    /// `trace`: radiance from the scene along a direction, per fragment.
    Trace(Value),
    /// `occlusion`: ambient occlusion from the scene, per fragment.
    Occlusion(Value),
    /// The light samples of light set `set` (at a point other than the stream `P`), for the
    /// light loop `region`.
    LightSamples {
        /// The `Illuminance` value.
        region: Value,
        /// Index into [`Layout::light_sets`].
        set: usize,
    },
}

/// A step the host runs between passes: read values back, ask the scene, upload results.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostStep {
    /// What it does.
    pub kind: HostKind,
    /// For which fragments (the others get zeros, or no samples).
    pub guard: Guard,
    /// Values it reads from `sn_tmp` (operands and guard conditions that the host cannot
    /// evaluate itself).
    pub reads: Vec<Value>,
}

/// One GPU pass: a kernel over every fragment of a batch.
#[derive(Clone, Debug, PartialEq)]
pub struct Pass {
    /// Its items, in order.
    pub items: Vec<Item>,
    /// The guard every item shares (the kernel returns early where it fails; the host skips
    /// the dispatch when it can tell it fails for all fragments).
    pub guard: Guard,
    /// Values it loads from `sn_tmp`.
    pub loads: Vec<Value>,
    /// Values it stores to `sn_tmp` for later steps.
    pub stores: Vec<Value>,
    /// Outputs it writes (indices into `Program::outputs`).
    pub outputs: Vec<usize>,
    /// Sum of its items' costs.
    pub cost: usize,
    /// Whether it runs a light loop (binds `sn_light`).
    pub lights: bool,
    /// Whether it reads textures (binds `sn_texels` and `sn_tex_info`).
    pub textures: bool,
    /// Its WGSL kernel.
    pub wgsl: String,
}

/// One step of a plan.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// A GPU pass.
    Pass(Pass),
    /// A host step.
    Host(HostStep),
}

/// The light samples of one or more light loops at the same point.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LightSet {
    /// The point the samples are seen from: `None` for the stream `P` (computed by the host
    /// before the first pass), else the value a host step reads back first.
    pub point: Option<Value>,
    /// Whether some light loop of the set reads `light.visible` (then, with a scene, the host
    /// casts a shadow ray per sample).
    pub visible: bool,
}

/// Where everything lives in the buffers, shared by the kernels and the host.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// The streams in `sn_frag`, each with its first column, in [`Stream::ALL`] order.
    pub streams: Vec<(Stream, usize)>,
    /// The column of the fragment's seed (bits) in `sn_frag`.
    pub seed: usize,
    /// Columns of `sn_frag`.
    pub frag_columns: usize,
    /// The outputs in `sn_out` (the interpreter's layout).
    pub outputs: Vec<OutputSlot>,
    /// Columns of `sn_out`.
    pub out_columns: usize,
    /// First uniform slot of each prelude value, by arena index.
    pub prelude: HashMap<usize, usize>,
    /// First uniform slot of each parameter read outside the prelude, by parameter index.
    pub params: HashMap<u32, usize>,
    /// Slots of `sn_uni`.
    pub uniforms: usize,
    /// First `sn_tmp` column of each value that crosses a step boundary, by arena index.
    pub tmp: Vec<Option<usize>>,
    /// Columns of `sn_tmp`.
    pub tmp_columns: usize,
    /// Columns `sn_tmp` would take without reuse (the sum of the crossing values' widths).
    pub tmp_columns_no_reuse: usize,
    /// Light sets: each has `7 × S` columns in `sn_light`, set after set.
    pub light_sets: Vec<LightSet>,
    /// Whether some kernel reads textures.
    pub textures: bool,
}

/// A program planned for the GPU: steps, layouts, limits. See the module documentation.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The material's name.
    pub material: String,
    /// Passes and host steps, in order.
    pub steps: Vec<Step>,
    /// Buffer layouts.
    pub layout: Layout,
    /// The options it was planned with.
    pub options: GpuOptions,
    /// Most fragments per batch that the adapter's limits allow, light samples not counted
    /// (see [`Plan::max_batch`]).
    pub limit_batch: usize,
    /// The adapter's largest storage buffer binding, in bytes.
    pub binding_size: u64,
    /// Storage buffers per shader stage the adapter allows.
    pub buffers_per_stage: u32,
    /// Ops in the program (prelude and body).
    pub ops: usize,
    /// Printer names (`%N` of the IR text form) by arena index.
    pub(crate) names: Vec<Option<u32>>,
    /// For each region (by arena index): its `proj` users as (value, result index).
    pub(crate) projs: HashMap<usize, Vec<(Value, u8)>>,
    /// Step index that defines each value (by arena index), for values computed by a step.
    pub(crate) def: Vec<Option<usize>>,
    /// Columns of each value's type (0 for regions), by arena index.
    pub(crate) widths: Vec<usize>,
}

/// One WGSL kernel of a plan.
#[derive(Clone, Copy, Debug)]
pub struct Kernel<'a> {
    /// Its step index in [`Plan::steps`].
    pub step: usize,
    /// Its pass number (0, 1, …).
    pub pass: usize,
    /// The WGSL source.
    pub wgsl: &'a str,
}

impl Plan {
    /// The passes' kernels, in order.
    pub fn kernels(&self) -> Vec<Kernel<'_>> {
        let mut out = Vec::new();
        for (step, s) in self.steps.iter().enumerate() {
            if let Step::Pass(p) = s {
                out.push(Kernel {
                    step,
                    pass: out.len(),
                    wgsl: &p.wgsl,
                });
            }
        }
        out
    }

    /// Ops the passes compute in all (the cost model's unit; host steps count none). Every
    /// partition of a program computes the same ops.
    pub fn ops(&self) -> usize {
        self.steps
            .iter()
            .map(|s| match s {
                Step::Pass(p) => p.cost,
                Step::Host(_) => 0,
            })
            .sum()
    }

    /// Number of passes.
    pub fn passes(&self) -> usize {
        self.steps
            .iter()
            .filter(|s| matches!(s, Step::Pass(_)))
            .count()
    }

    /// Number of host steps.
    pub fn host_steps(&self) -> usize {
        self.steps.len() - self.passes()
    }

    /// Lines of WGSL, all kernels together.
    pub fn wgsl_lines(&self) -> usize {
        self.kernels().iter().map(|k| k.wgsl.lines().count()).sum()
    }

    /// Bytes of WGSL, all kernels together.
    pub fn wgsl_bytes(&self) -> usize {
        self.kernels().iter().map(|k| k.wgsl.len()).sum()
    }

    /// Columns of `sn_light` with `samples` light samples per fragment.
    pub fn light_columns(&self, samples: usize) -> usize {
        LIGHT_COLUMNS * samples * self.layout.light_sets.len()
    }

    /// Most fragments per batch with `samples` light samples per fragment: the adapter's
    /// limits (binding size of every per-fragment buffer, workgroups per dispatch) and
    /// [`GpuOptions::batch`]; at least 1.
    pub fn max_batch(&self, samples: usize) -> usize {
        let mut m = self.limit_batch.min(self.options.batch);
        let cols = self.light_columns(samples) as u64;
        if cols > 0 {
            m = m.min((self.binding_size / (4 * cols)) as usize);
        }
        m.max(1)
    }

    /// The `%N` name of a value (as `--emit ir` prints it).
    pub fn name(&self, v: Value) -> String {
        value_name(&self.names, v)
    }

    /// All kernels as one text, each after a comment line naming its pass (what
    /// `shadenet compile --emit wgsl` prints).
    pub fn wgsl(&self) -> String {
        let mut s = String::new();
        for k in self.kernels() {
            s.push_str(&format!(
                "// ---- material `{}`, pass {} (step {}) ----\n",
                self.material, k.pass, k.step
            ));
            s.push_str(k.wgsl);
            if !k.wgsl.ends_with('\n') {
                s.push('\n');
            }
        }
        s
    }
}

pub(crate) fn value_name(names: &[Option<u32>], v: Value) -> String {
    match names.get(v.index()).copied().flatten() {
        Some(n) => format!("%{n}"),
        None => format!("%v{}", v.index()),
    }
}

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

/// How values are encoded in `f32` buffer columns (`sn_uni`, `sn_tmp`): floats as they are,
/// ints as their bits, bools as 0/1, strings as 0; matrices as 16 floats, row-major.
pub fn encode_const(c: &ConstValue) -> Vec<f32> {
    match c {
        ConstValue::Bool(b) => vec![if *b { 1.0 } else { 0.0 }],
        ConstValue::Int(i) => vec![f32::from_bits(*i as u32)],
        ConstValue::String(_) => vec![0.0],
        ConstValue::Float(x) => vec![*x as f32],
        ConstValue::Vec2(v) => v.iter().map(|x| *x as f32).collect(),
        ConstValue::Vec3(v) | ConstValue::Color(v) => v.iter().map(|x| *x as f32).collect(),
        ConstValue::Matrix44(m) => m.iter().map(|x| *x as f32).collect(),
    }
}

/// Whether a value is not computed by any step: constants, parameters, prelude values,
/// streams, the component mask, ambient light and the current light sample are read where
/// they are used (kernels load them from `sn_uni`/`sn_frag`/`sn_light`; the host evaluates
/// them itself).
pub(crate) fn is_remat(p: &Program, prelude: &HashMap<usize, usize>, v: Value) -> bool {
    prelude.contains_key(&v.index())
        || matches!(
            p.op(v),
            Op::Const(_)
                | Op::Param(_)
                | Op::Stream(_)
                | Op::ComponentEnabled(_)
                | Op::Ambient
                | Op::LightL
                | Op::LightCl
                | Op::LightVisible
        )
}

/// Values read by `block` (operands, conditions, yields, at any depth) that it does not
/// define itself.
pub(crate) fn free_values(p: &Program, block: &Block) -> BTreeSet<Value> {
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

fn guard_text(names: &[Option<u32>], g: &Guard) -> String {
    if g.is_empty() {
        return "-".into();
    }
    g.iter()
        .map(|(c, pol)| {
            let n = value_name(names, *c);
            if *pol { n } else { format!("!{n}") }
        })
        .collect::<Vec<_>>()
        .join(" && ")
}

impl Plan {
    fn values_text(&self, vs: &[Value]) -> String {
        if vs.is_empty() {
            return "-".into();
        }
        vs.iter()
            .map(|v| {
                let w = self
                    .layout
                    .tmp
                    .get(v.index())
                    .copied()
                    .flatten()
                    .zip(self.ty_width(*v));
                match w {
                    Some((c, w)) if w > 1 => format!("{}@{}..{}", self.name(*v), c, c + w),
                    Some((c, _)) => format!("{}@{}", self.name(*v), c),
                    None => self.name(*v),
                }
            })
            .collect::<Vec<_>>()
            .join(" ")
    }

    fn ty_width(&self, v: Value) -> Option<usize> {
        self.widths.get(v.index()).copied()
    }
}

impl fmt::Display for Plan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let l = &self.layout;
        let mode = match self.options.passes {
            PassMode::Auto => format!("auto, op budget {}", self.options.op_budget),
            PassMode::Fused => "fused".into(),
            PassMode::Count(n) => format!("{n} passes asked"),
        };
        writeln!(
            f,
            "gpu plan of `{}`: {} passes, {} host steps ({mode})",
            self.material,
            self.passes(),
            self.host_steps()
        )?;
        let streams: Vec<&str> = l.streams.iter().map(|(s, _)| s.name()).collect();
        writeln!(
            f,
            "  sn_frag: {} columns ({} seed); sn_out: {} columns; sn_uni: {} floats",
            l.frag_columns,
            streams.join(" "),
            l.out_columns,
            l.uniforms
        )?;
        if !l.light_sets.is_empty() {
            let sets: Vec<String> = l
                .light_sets
                .iter()
                .map(|s| {
                    let at = s.point.map_or("P".to_string(), |v| self.name(v));
                    if s.visible {
                        format!("at {at} with shadow rays")
                    } else {
                        format!("at {at}")
                    }
                })
                .collect();
            writeln!(f, "  light sets: {}", sets.join("; "))?;
        }
        let mut pass_no = 0;
        for (s, st) in self.steps.iter().enumerate() {
            match st {
                Step::Pass(ps) => {
                    let outs: Vec<String> = ps
                        .outputs
                        .iter()
                        .map(|&k| {
                            let o = &l.outputs[k];
                            format!("{}@{}", o.name, o.offset)
                        })
                        .collect();
                    writeln!(
                        f,
                        "  pass {pass_no} (step {s}): {} ops in {} items, guard {}, loads {}, \
                         stores {}, outputs {}{}{}, {} WGSL lines",
                        ps.cost,
                        ps.items.len(),
                        guard_text(&self.names, &ps.guard),
                        self.values_text(&ps.loads),
                        self.values_text(&ps.stores),
                        if outs.is_empty() {
                            "-".into()
                        } else {
                            outs.join(" ")
                        },
                        if ps.lights { ", light loop" } else { "" },
                        if ps.textures { ", textures" } else { "" },
                        ps.wgsl.lines().count()
                    )?;
                    pass_no += 1;
                }
                Step::Host(h) => {
                    let what = match &h.kind {
                        HostKind::Trace(v) => format!("trace {}", self.name(*v)),
                        HostKind::Occlusion(v) => format!("occlusion {}", self.name(*v)),
                        HostKind::LightSamples { region, set } => {
                            format!("light samples (set {set}) for {}", self.name(*region))
                        }
                    };
                    let writes = match &h.kind {
                        HostKind::Trace(v) | HostKind::Occlusion(v) => self.values_text(&[*v]),
                        HostKind::LightSamples { set, .. } => format!("sn_light set {set}"),
                    };
                    writeln!(
                        f,
                        "  host (step {s}): {what}, guard {}, reads {}, writes {writes}",
                        guard_text(&self.names, &h.guard),
                        self.values_text(&h.reads),
                    )?;
                }
            }
        }
        let cost = self.ops();
        writeln!(
            f,
            "  sn_tmp: {} columns ({} without reuse); at most {} fragments per batch \
             (binding size {} bytes, {} storage buffers per stage)",
            l.tmp_columns,
            l.tmp_columns_no_reuse,
            self.limit_batch.min(self.options.batch),
            self.binding_size,
            self.buffers_per_stage
        )?;
        writeln!(
            f,
            "  total: {} ops of {} in {} passes and {} host steps; {} WGSL lines, {} bytes",
            cost,
            self.ops,
            self.passes(),
            self.host_steps(),
            self.wgsl_lines(),
            self.wgsl_bytes()
        )
    }
}
