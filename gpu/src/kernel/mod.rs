//! One WGSL compute kernel per pass of a [`Plan`] (docs/gpu.md, "Data layout" and "Plan").
//!
//! Owns: the bindings (`sn_uni`, `sn_frag`, `sn_out`, `sn_tmp`, and where a pass needs them
//! `sn_light`, `sn_texels`, `sn_tex_info`), the entry point (`@compute @workgroup_size(W)`, one
//! invocation per fragment, `if (i >= n) { return; }`), the loads of streams, uniforms and
//! `sn_tmp` columns, the pass's guard as an early return, every value as a function-scope `var`
//! (so a value assigned under a guard stays visible to the merge after it), guarded items as
//! nested `if` blocks, merges as `select`, the light loop (`for (var j = 0u; j < S; j++)` over
//! the samples the host wrote, the body's yields summed from zero in sample order as the
//! interpreter does), loops (a WGSL `loop` over the carried values' `var`s, stopped at the
//! iteration limit: `writer::loops`), and the stores of crossing values and outputs. The ops
//! that are not pure are written here: streams, parameters and prelude values (loads),
//! `transform` (the uniform matrices, through world space, normals by the inverse transpose, as
//! `runtime::interp::transform`), `component_enabled` (the mask), `ambient`, the light sample,
//! `texture` (`sn_texture`), `proj`; every pure op comes from [`emit::op_expr`]. Every float
//! value (and float constant) is assigned behind a value barrier (an XOR with a uniform zero)
//! so that the shader compiler cannot rewrite arithmetic across IR ops: see `writer::keep` for
//! why.
//!
//! [`validate`] runs naga's WGSL front end and validator on a kernel.
//!
//! This module writes a kernel part by part ([`write`]); `writer` writes the statements
//! of the values and items, `library` what the kernel includes of the WGSL libraries.
//!
//! Must not touch: the plan itself (which items, which columns: [`crate::planner`] decides,
//! [`crate::plan`](mod@crate::plan) holds); the WGSL of pure ops and the intrinsic library
//! ([`crate::emit`]); wgpu devices ([`crate::material`]). It reads the plan's types only.

mod library;
mod writer;

use crate::emit;
use crate::plan::{
    ItemKind, Pass, Plan, Step, U_AMBIENT, U_KEEP, U_MASK, U_N, U_SAMPLES, is_remat,
};
use library::{TRANSFORM_HELPERS, library_for};
use shadenet_graph::ir::{Op, Program, Value};
use shadenet_runtime::BackendError;
use std::collections::BTreeSet;
use std::fmt::Write as _;
use writer::{Writer, line};

/// A written kernel.
pub(crate) struct KernelText {
    /// The WGSL source.
    pub wgsl: String,
    /// Whether it reads textures.
    pub textures: bool,
    /// Whether it reads the albedo tables (binds `sn_tables`).
    pub tables: bool,
}

/// Checks a WGSL kernel with naga (parse and validate); the error text names the line.
pub fn validate(wgsl: &str) -> Result<(), String> {
    let module = naga::front::wgsl::parse_str(wgsl).map_err(|e| e.emit_to_string(wgsl))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module)
    .map_err(|e| e.emit_to_string(wgsl))?;
    Ok(())
}

/// Writes the kernel of the pass at `plan.steps[step]` (pass number `pass_no`).
pub(crate) fn write(
    p: &Program,
    plan: &Plan,
    step: usize,
    pass_no: usize,
) -> Result<KernelText, BackendError> {
    let Some(Step::Pass(pass)) = plan.steps.get(step) else {
        return Err(BackendError::Codegen {
            backend: "gpu",
            material: p.name.clone(),
            message: format!("step {step} is not a pass"),
        });
    };
    let mut w = Writer::new(p, plan, pass_no, pass.outputs.clone());
    let locals = pass_locals(&w, p, plan, pass);
    w.locals = locals.iter().copied().collect();
    // The pass's guard (an early return), then the items under their remaining guards.
    let guard = pass_guard(&mut w, pass)?;
    let before_guard = (w.remat.clone(), w.loads.clone());
    let body = pass_body(&mut w, p, plan, pass, step)?;
    let entry = entry_point(&w, plan, pass, &guard, &before_guard, &locals, &body)?;
    let (wgsl, tables) = assemble(&w, p, pass, pass_no, &entry);
    Ok(KernelText {
        wgsl,
        textures: w.uses_textures,
        tables,
    })
}

/// The values the pass assigns (declared as function-scope `var`s), sorted: its items'
/// values, the results of its merges, and every value inside its light loops and loops.
fn pass_locals(w: &Writer<'_>, p: &Program, plan: &Plan, pass: &Pass) -> Vec<Value> {
    let remat = |v: Value| is_remat(p, &plan.layout.prelude, v);
    let mut locals: Vec<Value> = Vec::new();
    for it in &pass.items {
        match &it.kind {
            ItemKind::Value(v) => locals.push(*v),
            ItemKind::Merge(r) => locals.extend(w.projs(*r).into_iter().map(|x| x.0)),
            ItemKind::Loop { region } => {
                for b in p.op(*region).blocks() {
                    p.walk(b, &mut |v| {
                        if !remat(v) && p.expr(v).ty.is_some() {
                            locals.push(v);
                        }
                    });
                }
                locals.extend(w.projs(*region).into_iter().map(|x| x.0));
            }
            ItemKind::Illuminance { region, .. } => {
                if let Op::Illuminance { body, .. } = p.op(*region) {
                    p.walk(body, &mut |v| {
                        if !remat(v) && p.expr(v).ty.is_some() {
                            locals.push(v);
                        }
                    });
                }
                locals.extend(w.projs(*region).into_iter().map(|x| x.0));
            }
        }
    }
    locals.sort();
    locals.dedup();
    locals
}

/// The pass's guard as WGSL conditions (the kernel returns early where one fails).
fn pass_guard(w: &mut Writer<'_>, pass: &Pass) -> Result<Vec<String>, BackendError> {
    let mut guard_expr = Vec::new();
    for &(c, pol) in &pass.guard {
        let e = w.arg(c);
        guard_expr.push(if pol { e } else { format!("!({e})") });
    }
    w.check()?;
    Ok(guard_expr)
}

/// The statements of the pass's items, each under the part of its guard the pass does not
/// share (nested `if` blocks, `} else {` for the other arm of the same condition), then the
/// outputs the pass writes that no item of it computes.
fn pass_body(
    w: &mut Writer<'_>,
    p: &Program,
    plan: &Plan,
    pass: &Pass,
    step: usize,
) -> Result<String, BackendError> {
    let prefix = pass.guard.len();
    let mut body = String::new();
    let mut open: Vec<(Value, bool)> = Vec::new();
    for it in &pass.items {
        let g = it.guard.get(prefix..).unwrap_or(&[]);
        let mut common = open.iter().zip(g).take_while(|(a, b)| a == b).count();
        while open.len() > common + 1 {
            open.pop();
            line(&mut body, 1 + open.len(), "}");
        }
        if open.len() == common + 1 {
            // The other arm of the same condition right after this one: `} else {`.
            let (c0, p0) = open[common];
            if g.get(common) == Some(&(c0, !p0)) {
                line(&mut body, 1 + common, "} else {");
                open[common] = (c0, !p0);
                common += 1;
            } else {
                open.pop();
                line(&mut body, 1 + open.len(), "}");
            }
        }
        for &(c, pol) in &g[common..] {
            let e = w.arg(c);
            w.check()?;
            let text = if pol {
                format!("if ({e}) {{")
            } else {
                format!("if (!({e})) {{")
            };
            line(&mut body, 1 + open.len(), &text);
            open.push((c, pol));
        }
        w.item(&mut body, 1 + open.len(), &it.kind)?;
    }
    while open.pop().is_some() {
        line(&mut body, 1 + open.len(), "}");
    }
    // Outputs this pass writes that no item of it computes (constants, uniforms, streams,
    // results of host steps): the plan gives such a pass no guard.
    for &k in &pass.outputs {
        let v = p.outputs[k].value;
        if plan.def.get(v.index()).copied().flatten() != Some(step) {
            let e = w.arg(v);
            w.check()?;
            w.output_store(&mut body, 1, k, &e);
        }
    }
    Ok(body)
}

/// The entry point: the fragment index and the early return past `n`, the uniforms it reads,
/// the loads needed before the guard (`before_guard`: values and `sn_tmp` loads), the guard's
/// early return, the other loads, the `var`s of `locals`, then `body`.
fn entry_point(
    w: &Writer<'_>,
    plan: &Plan,
    pass: &Pass,
    guard: &[String],
    before_guard: &(BTreeSet<Value>, BTreeSet<Value>),
    locals: &[Value],
    body: &str,
) -> Result<String, BackendError> {
    let (pre_remat, pre_loads) = before_guard;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n@compute @workgroup_size({})\nfn main(@builtin(global_invocation_id) sn_gid: vec3<u32>) {{",
        plan.options.workgroup_size
    );
    line(&mut s, 1, &format!("let n = bitcast<u32>(sn_uni[{U_N}u]);"));
    line(&mut s, 1, "let i = sn_gid.x;");
    line(&mut s, 1, "if (i >= n) {");
    line(&mut s, 2, "return;");
    line(&mut s, 1, "}");
    line(
        &mut s,
        1,
        &format!("let {} = bitcast<u32>(sn_uni[{U_KEEP}u]);", emit::KEY),
    );
    if w.uses_mask {
        line(
            &mut s,
            1,
            &format!("let sn_mask = bitcast<u32>(sn_uni[{U_MASK}u]);"),
        );
    }
    if pass.lights {
        line(
            &mut s,
            1,
            &format!("let sn_S = bitcast<u32>(sn_uni[{U_SAMPLES}u]);"),
        );
    }
    if w.uses_ambient {
        line(
            &mut s,
            1,
            &format!(
                "let sn_ambient = vec3<f32>(sn_uni[{}u], sn_uni[{}u], sn_uni[{}u]);",
                U_AMBIENT,
                U_AMBIENT + 1,
                U_AMBIENT + 2
            ),
        );
    }
    for &v in pre_remat {
        line(&mut s, 1, &w.remat_load(v)?);
    }
    for &v in pre_loads {
        line(&mut s, 1, &w.tmp_load(v)?);
    }
    if !guard.is_empty() {
        line(&mut s, 1, &format!("if (!({})) {{", guard.join(" && ")));
        line(&mut s, 2, "return;");
        line(&mut s, 1, "}");
    }
    for &v in w.remat.difference(pre_remat) {
        line(&mut s, 1, &w.remat_load(v)?);
    }
    for &v in w.loads.difference(pre_loads) {
        line(&mut s, 1, &w.tmp_load(v)?);
    }
    for &v in locals {
        let t = w.wgsl_type(v)?;
        line(&mut s, 1, &format!("var {}: {t};", w.name(v)));
    }
    s.push_str(body);
    s.push_str("}\n");
    Ok(s)
}

/// The whole kernel: a comment naming the material and the pass, what the entry point needs
/// of the libraries, the bindings the pass uses, the texture library and transform helpers
/// where it uses them, and the entry point; and whether its library reads the albedo tables
/// (`sn_tables`, then bound).
fn assemble(
    w: &Writer<'_>,
    p: &Program,
    pass: &Pass,
    pass_no: usize,
    entry: &str,
) -> (String, bool) {
    let mut extra = String::new();
    if w.uses_textures {
        extra.push_str(emit::TEXTURE_LIBRARY);
        if !extra.ends_with('\n') {
            extra.push('\n');
        }
    }
    if w.uses_xf {
        extra.push_str(TRANSFORM_HELPERS);
    }
    let mut s = String::new();
    let _ = writeln!(
        s,
        "// shadenet: material `{}`, pass {pass_no}",
        p.name.replace(['\n', '\r'], " ")
    );
    let library = library_for(emit::library(), &format!("{extra}{entry}"));
    let tables = library.contains("sn_tables");
    s.push_str(&library);
    if !s.ends_with('\n') {
        s.push('\n');
    }
    s.push_str("\n@group(0) @binding(0) var<storage, read> sn_uni: array<f32>;\n");
    s.push_str("@group(0) @binding(1) var<storage, read> sn_frag: array<f32>;\n");
    s.push_str("@group(0) @binding(2) var<storage, read_write> sn_out: array<f32>;\n");
    s.push_str("@group(0) @binding(3) var<storage, read_write> sn_tmp: array<f32>;\n");
    if pass.lights {
        s.push_str("@group(0) @binding(4) var<storage, read> sn_light: array<f32>;\n");
    }
    if w.uses_textures {
        s.push_str("@group(0) @binding(5) var<storage, read> sn_texels: array<vec4<f32>>;\n");
        s.push_str("@group(0) @binding(6) var<storage, read> sn_tex_info: array<vec4<u32>>;\n");
    }
    if tables {
        s.push_str(emit::TABLES_DECLARATION);
    }
    s.push_str(&extra);
    s.push_str(entry);
    (s, tables)
}
