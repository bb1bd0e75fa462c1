//! The planner: cuts one program into a [`Plan`] (docs/gpu.md, "Plan").
//!
//! Owns: the planning pipeline, [`plan`], one phase after another: the program checks, the
//! fixed buffer layouts (fragment streams, outputs, uniforms), linearization into items and
//! host steps (`linearize`), the cut into passes (`partition`), definitions, uses, live
//! ranges and `sn_tmp` columns (`liveness`), the adapter's limits, and the kernels.
//!
//! [`plan`] needs no device: it takes the adapter's [`wgpu::Limits`] (callers without a
//! device pass `wgpu::Limits::default()`), has every pass's WGSL kernel written
//! ([`crate::kernel`]) and validates it with naga, so an invalid kernel is a
//! [`BackendError::Codegen`] naming the material and the pass, never a wgpu panic.
//!
//! Must not touch: the plan's types and their printing ([`crate::plan`](mod@crate::plan)), the text of a
//! kernel ([`crate::kernel`]), wgpu devices, buffers and dispatch ([`crate::material`]); the
//! WGSL form of pure ops ([`crate::emit`]).

mod linearize;
mod liveness;
mod partition;

use crate::emit;
use crate::kernel;
use crate::options::GpuOptions;
use crate::plan::{Layout, Plan, Step, U_VALUES};
use shadenet_graph::ir::{Block, Op, Program, Stream, Value};
use shadenet_graph::opt::needs;
use shadenet_runtime::BackendError;
use shadenet_runtime::interp::{OutputSlot, output_layout};
use std::collections::HashMap;

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
    check(p, options, limits)?;
    let names = number_values(p);
    let fixed = FixedLayout::of(p);
    let projs = projections(p);
    let (entries, light_sets) = linearize::linearize(p, &fixed.prelude, &names)?;
    let mut raw = partition::cut(entries, options);
    let flow = liveness::flow(p, &mut raw, &fixed.prelude, &projs);
    let tmp = liveness::tmp_columns(p, &names, &raw, &flow)?;
    let steps = liveness::steps(p, raw, &flow, &tmp.tmp);
    let layout = Layout {
        streams: fixed.streams,
        seed: fixed.seed,
        frag_columns: fixed.frag_columns,
        outputs: fixed.outputs,
        out_columns: fixed.out_columns,
        prelude: fixed.prelude,
        params: fixed.params,
        uniforms: fixed.uniforms,
        tmp: tmp.tmp,
        tmp_columns: tmp.columns,
        tmp_columns_no_reuse: tmp.no_reuse,
        light_sets,
        textures: false,
        tables: false,
    };
    let (limit_batch, binding) = batch_limit(p, &layout, options, limits)?;
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
        def: flow.def,
        widths: p
            .exprs
            .iter()
            .map(|e| e.ty.map_or(0, emit::columns))
            .collect(),
    };
    write_kernels(p, &mut plan, limits)?;
    Ok(plan)
}

/// A limit of the adapter the program does not fit in: [`BackendError::Unsupported`] for the
/// whole program (the material falls back).
fn limit_err(p: &Program, reason: String) -> BackendError {
    BackendError::Unsupported {
        backend: "gpu",
        material: p.name.clone(),
        op: "the program".into(),
        reason,
    }
}

/// Checks before planning: the program is valid IR, and the workgroup size is one the
/// adapter allows.
fn check(p: &Program, options: &GpuOptions, limits: &wgpu::Limits) -> Result<(), BackendError> {
    shadenet_graph::ir::validate(p).map_err(|e| BackendError::Codegen {
        backend: "gpu",
        material: p.name.clone(),
        message: format!("the program is not valid: {e}"),
    })?;
    if options.workgroup_size == 0
        || options.workgroup_size > limits.max_compute_invocations_per_workgroup
        || options.workgroup_size > limits.max_compute_workgroup_size_x
    {
        return Err(limit_err(
            p,
            format!(
                "workgroup size {} is outside what the adapter allows (1..={})",
                options.workgroup_size,
                limits
                    .max_compute_invocations_per_workgroup
                    .min(limits.max_compute_workgroup_size_x)
            ),
        ));
    }
    Ok(())
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

/// The layouts fixed by the program alone, before any step: fragment streams, outputs and
/// uniform slots (see [`Layout`] for each field).
struct FixedLayout {
    streams: Vec<(Stream, usize)>,
    seed: usize,
    frag_columns: usize,
    outputs: Vec<OutputSlot>,
    out_columns: usize,
    prelude: HashMap<usize, usize>,
    params: HashMap<u32, usize>,
    uniforms: usize,
}

impl FixedLayout {
    /// The streams the program reads (in [`Stream::ALL`] order) and the seed in `sn_frag`;
    /// the interpreter's output layout; prelude values, then parameters read outside the
    /// prelude, in `sn_uni` from [`U_VALUES`] on.
    fn of(p: &Program) -> FixedLayout {
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
        FixedLayout {
            streams,
            seed,
            frag_columns,
            outputs,
            out_columns,
            prelude,
            params,
            uniforms,
        }
    }
}

/// The `proj` users of each region (by arena index) as (value, result index).
fn projections(p: &Program) -> HashMap<usize, Vec<(Value, u8)>> {
    let mut projs: HashMap<usize, Vec<(Value, u8)>> = HashMap::new();
    for v in p.listed() {
        if let Op::Proj(r, k) = p.op(v) {
            projs.entry(r.index()).or_default().push((v, *k));
        }
    }
    projs
}

/// The most fragments per batch the adapter's limits allow (the binding size of the widest
/// per-fragment buffer, workgroups per dispatch), and the binding size in bytes; an error
/// when not even one fragment fits.
fn batch_limit(
    p: &Program,
    layout: &Layout,
    options: &GpuOptions,
    limits: &wgpu::Limits,
) -> Result<(usize, u64), BackendError> {
    let per_fragment = [layout.frag_columns, layout.out_columns, layout.tmp_columns]
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
        return Err(limit_err(
            p,
            format!(
                "one fragment needs {} bytes in one buffer; the adapter binds at most {binding}",
                4 * per_fragment
            ),
        ));
    }
    Ok((limit_batch, binding))
}

/// Writes every pass's kernel into the plan, checks the storage buffers they bind against
/// the adapter's limit, and validates each kernel with naga.
fn write_kernels(p: &Program, plan: &mut Plan, limits: &wgpu::Limits) -> Result<(), BackendError> {
    let mut kernels = Vec::new();
    let mut pass_no = 0;
    for s in 0..plan.steps.len() {
        if let Step::Pass(_) = &plan.steps[s] {
            let k = kernel::write(p, plan, s, pass_no)?;
            kernels.push((s, k));
            pass_no += 1;
        }
    }
    for (s, k) in kernels {
        if let Step::Pass(pass) = &mut plan.steps[s] {
            pass.textures = k.textures;
            pass.tables = k.tables;
            pass.wgsl = k.wgsl;
            plan.layout.textures |= k.textures;
            plan.layout.tables |= k.tables;
        }
    }
    let need = 4
        + u32::from(!plan.layout.light_sets.is_empty())
        + if plan.layout.textures { 2 } else { 0 }
        + u32::from(plan.layout.tables);
    if need > limits.max_storage_buffers_per_shader_stage {
        return Err(limit_err(
            p,
            format!(
                "the kernels bind {need} storage buffers; the adapter allows {} per shader stage",
                limits.max_storage_buffers_per_shader_stage
            ),
        ));
    }
    for k in plan.kernels() {
        kernel::validate(k.wgsl).map_err(|message| BackendError::Codegen {
            backend: "gpu",
            material: p.name.clone(),
            message: format!("pass {}: naga rejects the kernel: {message}", k.pass),
        })?;
    }
    Ok(())
}
