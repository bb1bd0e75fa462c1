//! One WGSL compute kernel per pass of a [`Plan`] (docs/gpu.md, "Data layout" and "Plan").
//!
//! Owns: the bindings (`sn_uni`, `sn_frag`, `sn_out`, `sn_tmp`, and where a pass needs them
//! `sn_light`, `sn_texels`, `sn_tex_info`), the entry point (`@compute
//! @workgroup_size(W)`, one invocation per fragment, `if (i >= n) { return; }`), the loads
//! of streams, uniforms and `sn_tmp` columns, the pass's guard as an early return, every
//! value as a function-scope `var` (so a value assigned under a guard stays visible to the
//! merge after it), guarded items as nested `if` blocks, merges as `select`, the light loop
//! (`for (var j = 0u; j < S; j++)` over the samples the host wrote, the body's yields summed
//! from zero in sample order as the interpreter does), and the stores of crossing values and
//! outputs. The ops that are not pure are written here: streams, parameters and prelude
//! values (loads), `transform` (the uniform matrices, through world space, normals by the
//! inverse transpose, as `runtime::interp::transform`), `component_enabled` (the mask),
//! `ambient`, the light sample, `texture` (`sn_texture`), `proj`; every pure op comes from
//! [`emit::op_expr`]. Every float value (and float constant) is assigned behind a value
//! barrier (an XOR with a uniform zero) so that the shader compiler cannot rewrite
//! arithmetic across IR ops: see [`keep`] for why.
//!
//! [`validate`] runs naga's WGSL front end and validator on a kernel.
//!
//! Must not touch: the plan itself (which items, which columns: [`crate::planner`] decides,
//! [`crate::plan`] holds); the WGSL of pure ops and the intrinsic library
//! ([`crate::emit`]); wgpu devices ([`crate::material`]). It reads the plan's types only.

use crate::emit;
use crate::plan::{
    ItemKind, LIGHT_COLUMNS, Plan, Step, U_AMBIENT, U_CAMERA, U_CAMERA_INV, U_KEEP, U_MASK, U_N,
    U_OBJECT, U_OBJECT_INV, U_SAMPLES, is_remat, value_name,
};
use shadenet_graph::ir::{Block, Op, Program, Space, Value, XformKind};
use shadenet_graph::types::{ConstValue, Type};
use shadenet_runtime::BackendError;
use std::collections::{BTreeSet, HashSet};
use std::fmt::Write as _;

/// A written kernel.
pub(crate) struct KernelText {
    /// The WGSL source.
    pub wgsl: String,
    /// Whether it reads textures.
    pub textures: bool,
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

/// The matrices' uniform slots for a transform helper: the matrix a point or vector is
/// multiplied by, and the one whose transpose a normal is multiplied by.
fn space_slots(s: Space) -> Option<(usize, usize)> {
    match s {
        Space::World => None,
        Space::Camera => Some((U_CAMERA, U_CAMERA_INV)),
        Space::Object => Some((U_OBJECT, U_OBJECT_INV)),
    }
}

/// The transform helpers: `ops::transform` with matrices in `sn_uni` at slot `b`, each
/// component summed left to right exactly as the Rust code does.
const TRANSFORM_HELPERS: &str = "
fn snk_xf_point(b: u32, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        sn_uni[b] * v.x + sn_uni[b + 1u] * v.y + sn_uni[b + 2u] * v.z + sn_uni[b + 3u],
        sn_uni[b + 4u] * v.x + sn_uni[b + 5u] * v.y + sn_uni[b + 6u] * v.z + sn_uni[b + 7u],
        sn_uni[b + 8u] * v.x + sn_uni[b + 9u] * v.y + sn_uni[b + 10u] * v.z + sn_uni[b + 11u]);
}

fn snk_xf_vector(b: u32, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        sn_uni[b] * v.x + sn_uni[b + 1u] * v.y + sn_uni[b + 2u] * v.z,
        sn_uni[b + 4u] * v.x + sn_uni[b + 5u] * v.y + sn_uni[b + 6u] * v.z,
        sn_uni[b + 8u] * v.x + sn_uni[b + 9u] * v.y + sn_uni[b + 10u] * v.z);
}

fn snk_xf_normal(b: u32, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        sn_uni[b] * v.x + sn_uni[b + 4u] * v.y + sn_uni[b + 8u] * v.z,
        sn_uni[b + 1u] * v.x + sn_uni[b + 5u] * v.y + sn_uni[b + 9u] * v.z,
        sn_uni[b + 2u] * v.x + sn_uni[b + 6u] * v.y + sn_uni[b + 10u] * v.z);
}
";

/// One top-level declaration of a WGSL library text: its name and its text (with the comment
/// lines after it, up to the next declaration).
struct LibItem<'a> {
    name: &'a str,
    text: &'a str,
}

/// Splits a WGSL library into its top-level declarations (`fn`, `const`, `struct`, `alias`,
/// `var`, `override` at the start of a line); `None` if some code is outside them (then the
/// library is included whole).
fn library_items(lib: &str) -> Option<(&str, Vec<LibItem<'_>>)> {
    let mut starts = Vec::new();
    let mut at = 0;
    for line in lib.split_inclusive('\n') {
        let name = ["fn ", "const ", "struct ", "alias ", "override "]
            .iter()
            .find_map(|k| line.strip_prefix(k))
            .or_else(|| {
                line.strip_prefix("var")
                    .and_then(|r| r.split_once('>').map(|x| x.1).or(Some(r)))
            })
            .map(|r| {
                let r = r.trim_start();
                let end = r
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                    .unwrap_or(r.len());
                &r[..end]
            });
        if let Some(name) = name.filter(|n| !n.is_empty()) {
            starts.push((at, name));
        }
        at += line.len();
    }
    let head = &lib[..starts.first().map_or(lib.len(), |s| s.0)];
    // Only comments and blank lines may come before the first declaration.
    if head
        .lines()
        .any(|l| !l.trim().is_empty() && !l.trim_start().starts_with("//"))
    {
        return None;
    }
    let items = starts
        .iter()
        .enumerate()
        .map(|(k, &(a, name))| LibItem {
            name,
            text: &lib[a..starts.get(k + 1).map_or(lib.len(), |s| s.0)],
        })
        .collect();
    Some((head, items))
}

/// Calls `f` on every identifier of a WGSL text (comments included: harmless, they can only
/// add declarations).
fn identifiers(text: &str, mut f: impl FnMut(&str)) {
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_alphabetic() || b[i] == b'_' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            f(&text[start..i]);
        } else {
            i += 1;
        }
    }
}

/// The declarations of `lib` that `code` needs (directly or through each other), in the
/// library's order: a kernel compiles faster without the rest (Mesa and LLVM see only what
/// the pass calls). The whole library when it cannot be split.
fn library_for(lib: &str, code: &str) -> String {
    let Some((head, items)) = library_items(lib) else {
        return lib.to_string();
    };
    let index: std::collections::HashMap<&str, usize> = items
        .iter()
        .enumerate()
        .map(|(k, it)| (it.name, k))
        .collect();
    let mut keep = vec![false; items.len()];
    let mut todo = Vec::new();
    let mark = |name: &str, keep: &mut Vec<bool>, todo: &mut Vec<usize>| {
        if let Some(&k) = index.get(name)
            && !keep[k]
        {
            keep[k] = true;
            todo.push(k);
        }
    };
    identifiers(code, |n| mark(n, &mut keep, &mut todo));
    while let Some(k) = todo.pop() {
        identifiers(items[k].text, |n| mark(n, &mut keep, &mut todo));
    }
    let mut out = String::from(head);
    for (it, k) in items.iter().zip(&keep) {
        if *k {
            out.push_str(it.text);
        }
    }
    out
}

struct Writer<'a> {
    p: &'a Program,
    plan: &'a Plan,
    pass_no: usize,
    /// Outputs this pass writes (indices into `Program::outputs`).
    outputs: Vec<usize>,
    /// Values assigned by this kernel (declared as `var`s).
    locals: HashSet<Value>,
    /// Streams, parameters and prelude values read (loaded once, as `let`s).
    remat: BTreeSet<Value>,
    /// Values of earlier steps read (loaded from `sn_tmp`).
    loads: BTreeSet<Value>,
    in_loop: bool,
    uses_mask: bool,
    uses_ambient: bool,
    uses_xf: bool,
    uses_textures: bool,
    /// The first error met inside an operand callback.
    err: Option<BackendError>,
}

/// The column `c` of buffer `buf` for this invocation's fragment.
fn col(buf: &str, c: usize) -> String {
    format!("{buf}[{c}u * n + i]")
}

fn line(out: &mut String, depth: usize, text: &str) {
    for _ in 0..depth {
        out.push_str("    ");
    }
    out.push_str(text);
    out.push('\n');
}

/// `e` behind the value barrier: its bits XOR the key ([`emit::KEY`], `sn_keep`), a uniform
/// that is 0 at run time but unknown to the shader compiler, for float-based types (other
/// types as they are).
///
/// WGSL has no way to ask for exact floating point, naga marks no SPIR-V op
/// `NoContraction`, and Mesa then treats every float op as inexact: it reassociates
/// products with constants, folds `x * 0.0` to `0.0` (NaN × 0 is NaN on the CPU), and so
/// on, differently depending on which ops share a kernel. Behind the barrier each IR value
/// is opaque to the optimizer, so a value is computed from its operands by its own op alone:
/// the same bits whether its users are in this kernel or in a later pass, and the same as
/// the interpreter's where the op itself is exact. Costs one integer XOR per component.
fn keep(ty: Type, e: &str) -> String {
    let k = emit::KEY;
    match ty {
        Type::Float => format!("bitcast<f32>(bitcast<u32>({e}) ^ {k})"),
        Type::Vec2 => format!("bitcast<vec2<f32>>(bitcast<vec2<u32>>({e}) ^ vec2<u32>({k}))"),
        Type::Vec3 | Type::Color => {
            format!("bitcast<vec3<f32>>(bitcast<vec3<u32>>({e}) ^ vec3<u32>({k}))")
        }
        _ => e.to_string(),
    }
}

/// A float constant (or matrix) behind the value barrier, so the shader compiler cannot
/// fold it into its users.
fn kept_const(c: &ConstValue) -> Option<String> {
    let row = |v: &[f64]| {
        let xs: Vec<String> = v.iter().map(|x| emit::float_literal(*x as f32)).collect();
        xs.join(", ")
    };
    Some(match c {
        ConstValue::Float(x) => keep(Type::Float, &emit::float_literal(*x as f32)),
        ConstValue::Vec2(v) => keep(Type::Vec2, &format!("vec2<f32>({})", row(v))),
        ConstValue::Vec3(v) | ConstValue::Color(v) => {
            keep(Type::Vec3, &format!("vec3<f32>({})", row(v)))
        }
        ConstValue::Matrix44(m) => {
            let rows: Vec<String> = m
                .chunks(4)
                .map(|r| {
                    format!(
                        "bitcast<vec4<f32>>(bitcast<vec4<u32>>(vec4<f32>({})) ^ vec4<u32>({}))",
                        row(r),
                        emit::KEY
                    )
                })
                .collect();
            format!("array<vec4<f32>, 4>({})", rows.join(", "))
        }
        _ => return None,
    })
}

/// Whether WGSL's `select` takes values of this type (scalars and vectors; not arrays).
fn selectable(ty: Type) -> bool {
    !matches!(ty, Type::Matrix44)
}

impl Writer<'_> {
    fn name(&self, v: Value) -> String {
        match self.plan.names.get(v.index()).copied().flatten() {
            Some(n) => format!("v{n}"),
            None => format!("x{}", v.index()),
        }
    }

    fn unsupported(&self, v: Value, reason: String) -> BackendError {
        BackendError::Unsupported {
            backend: "gpu",
            material: self.p.name.clone(),
            op: format!(
                "{} = {}",
                value_name(&self.plan.names, v),
                self.p.op(v).short_name()
            ),
            reason,
        }
    }

    fn codegen(&self, message: String) -> BackendError {
        BackendError::Codegen {
            backend: "gpu",
            material: self.p.name.clone(),
            message: format!("pass {}: {message}", self.pass_no),
        }
    }

    fn wgsl_type(&self, v: Value) -> Result<&'static str, BackendError> {
        let ty = self.p.ty(v);
        emit::wgsl_type(ty).map_err(|e| self.unsupported(v, e.to_string()))
    }

    fn projs(&self, region: Value) -> Vec<(Value, u8)> {
        self.plan
            .projs
            .get(&region.index())
            .cloned()
            .unwrap_or_default()
    }

    fn check(&mut self) -> Result<(), BackendError> {
        match self.err.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// The WGSL expression of an operand.
    fn arg(&mut self, v: Value) -> String {
        if self.plan.layout.prelude.contains_key(&v.index()) {
            self.remat.insert(v);
            return self.name(v);
        }
        match self.p.op(v) {
            Op::Const(c) if kept_const(c).is_some() => {
                self.remat.insert(v);
                self.name(v)
            }
            Op::Const(c) => match emit::literal(c) {
                Ok(s) => s,
                Err(e) => {
                    let err = self.unsupported(v, e.to_string());
                    self.err.get_or_insert(err);
                    "0".into()
                }
            },
            Op::Param(_) | Op::Stream(_) => {
                self.remat.insert(v);
                self.name(v)
            }
            Op::ComponentEnabled(k) => {
                self.uses_mask = true;
                format!("((sn_mask & {}u) != 0u)", 1u32 << (*k as u32 & 31))
            }
            Op::Ambient => {
                self.uses_ambient = true;
                "sn_ambient".into()
            }
            Op::LightL if self.in_loop => "sn_L".into(),
            Op::LightCl if self.in_loop => "sn_Cl".into(),
            Op::LightVisible if self.in_loop => "sn_vis".into(),
            Op::LightL | Op::LightCl => "vec3<f32>()".into(),
            Op::LightVisible => "f32(1.0)".into(),
            _ => {
                if !self.locals.contains(&v) {
                    self.loads.insert(v);
                }
                self.name(v)
            }
        }
    }

    /// The expression computing a (non-region) value.
    fn value_expr(&mut self, v: Value) -> Result<String, BackendError> {
        let p = self.p;
        let e = match p.op(v) {
            Op::Transform {
                kind,
                from,
                to,
                arg,
            } => {
                let mut e = self.arg(*arg);
                if from != to {
                    self.uses_xf = true;
                    let f = match kind {
                        XformKind::Point => "snk_xf_point",
                        XformKind::Vector => "snk_xf_vector",
                        XformKind::Normal => "snk_xf_normal",
                    };
                    // space → world by the inverse (normals: by the forward matrix,
                    // transposed), then world → space by the matrix (normals: the inverse,
                    // transposed).
                    if let Some((m, inv)) = space_slots(*from) {
                        let b = if *kind == XformKind::Normal { m } else { inv };
                        e = format!("{f}({b}u, {e})");
                        if to != &Space::World {
                            e = keep(Type::Vec3, &e);
                        }
                    }
                    if let Some((m, inv)) = space_slots(*to) {
                        let b = if *kind == XformKind::Normal { inv } else { m };
                        e = format!("{f}({b}u, {e})");
                    }
                }
                e
            }
            Op::Texture { texture, uv, alpha } => {
                self.uses_textures = true;
                let uv = self.arg(*uv);
                let sw = if *alpha { "w" } else { "xyz" };
                format!("sn_texture({texture}u, {uv}).{sw}")
            }
            Op::Trace { .. } | Op::Occlusion { .. } | Op::Illuminance { .. } | Op::If { .. } => {
                return Err(self.codegen(format!(
                    "{} is not a kernel item",
                    value_name(&self.plan.names, v)
                )));
            }
            _ => {
                let mut arg = |a: Value| self.arg(a);
                let r = emit::op_expr(p, v, &mut arg);
                r.map_err(|e| self.unsupported(v, e.to_string()))?
            }
        };
        self.check()?;
        Ok(e)
    }

    /// Stores of a value this pass defines: its `sn_tmp` columns if a later step reads it,
    /// its `sn_out` columns if it is an output written by this pass.
    fn stores(&mut self, out: &mut String, depth: usize, v: Value) {
        let ty = self.p.ty(v);
        let name = self.name(v);
        if let Some(c) = self.plan.layout.tmp.get(v.index()).copied().flatten() {
            for (k, e) in emit::store_columns(ty, &name).into_iter().enumerate() {
                line(out, depth, &format!("{} = {e};", col("sn_tmp", c + k)));
            }
        }
        for k in self.outputs.clone() {
            if self.p.outputs[k].value == v {
                self.output_store(out, depth, k, &name);
            }
        }
    }

    /// The columns of output `k` from the WGSL expression `e` of its value.
    fn output_store(&mut self, out: &mut String, depth: usize, k: usize, e: &str) {
        let slot = &self.plan.layout.outputs[k];
        let ty = slot.ty;
        let cols = if matches!(ty, Type::Matrix44 | Type::String) {
            // The interpreter writes no floats for these: they stay 0.
            vec!["0.0".to_string(); ty.width().max(1)]
        } else {
            emit::output_columns(ty, e)
        };
        for (c, x) in cols.into_iter().enumerate() {
            line(
                out,
                depth,
                &format!("{} = {x};", col("sn_out", slot.offset + c)),
            );
        }
    }

    fn item(
        &mut self,
        out: &mut String,
        depth: usize,
        kind: &ItemKind,
    ) -> Result<(), BackendError> {
        let p = self.p;
        match kind {
            ItemKind::Value(v) => {
                let e = keep(p.ty(*v), &self.value_expr(*v)?);
                line(out, depth, &format!("{} = {e};", self.name(*v)));
                self.stores(out, depth, *v);
            }
            ItemKind::Merge(r) => {
                let Op::If { cond, then_, else_ } = p.op(*r) else {
                    return Err(self.codegen("a merge of a value that is not an if".into()));
                };
                let c = self.arg(*cond);
                for (pv, k) in self.projs(*r) {
                    let (Some(t), Some(e)) =
                        (then_.yields.get(k as usize), else_.yields.get(k as usize))
                    else {
                        return Err(self.codegen(format!(
                            "{} reads a result the if does not have",
                            value_name(&self.plan.names, pv)
                        )));
                    };
                    let (t, e) = (self.arg(*t), self.arg(*e));
                    let name = self.name(pv);
                    if selectable(p.ty(pv)) {
                        line(out, depth, &format!("{name} = select({e}, {t}, {c});"));
                    } else {
                        line(
                            out,
                            depth,
                            &format!("if ({c}) {{ {name} = {t}; }} else {{ {name} = {e}; }}"),
                        );
                    }
                    self.stores(out, depth, pv);
                }
                self.check()?;
            }
            ItemKind::Illuminance { region, set } => {
                let Op::Illuminance { body, .. } = p.op(*region) else {
                    return Err(self.codegen("a light loop of a value that is not one".into()));
                };
                let r = self.name(*region);
                for (k, y) in body.yields.iter().enumerate() {
                    let t = self.wgsl_type(*y)?;
                    // The sums start from a zero the compiler cannot fold (`0 + y` is not
                    // `y` for y = -0).
                    let zero = keep(p.ty(*y), &format!("{t}()"));
                    line(out, depth, &format!("var sn_sum_{r}_{k}: {t} = {zero};"));
                }
                line(out, depth, "for (var j = 0u; j < sn_S; j++) {");
                let d = depth + 1;
                line(
                    out,
                    d,
                    &format!(
                        "let sn_c = {}u * sn_S * {set}u + {}u * j;",
                        LIGHT_COLUMNS, LIGHT_COLUMNS
                    ),
                );
                let light = |c: usize| format!("sn_light[(sn_c + {c}u) * n + i]");
                line(
                    out,
                    d,
                    &format!(
                        "let sn_L = vec3<f32>({}, {}, {});",
                        light(0),
                        light(1),
                        light(2)
                    ),
                );
                line(
                    out,
                    d,
                    &format!(
                        "let sn_Cl = vec3<f32>({}, {}, {});",
                        light(3),
                        light(4),
                        light(5)
                    ),
                );
                line(out, d, &format!("let sn_vis = {};", light(6)));
                self.in_loop = true;
                let r2 = self.structured(out, d, body);
                self.in_loop = false;
                r2?;
                self.in_loop = true;
                for (k, y) in body.yields.iter().enumerate() {
                    let e = self.arg(*y);
                    line(out, d, &format!("sn_sum_{r}_{k} = sn_sum_{r}_{k} + {e};"));
                }
                self.in_loop = false;
                line(out, depth, "}");
                for (pv, k) in self.projs(*region) {
                    line(out, depth, &format!("{} = sn_sum_{r}_{k};", self.name(pv)));
                    self.stores(out, depth, pv);
                }
                self.check()?;
            }
        }
        Ok(())
    }

    /// A block inside a light loop, as structured WGSL: an `if` runs only its taken arm, as
    /// in the interpreter.
    fn structured(
        &mut self,
        out: &mut String,
        depth: usize,
        block: &Block,
    ) -> Result<(), BackendError> {
        let p = self.p;
        for &v in &block.body {
            if is_remat(p, &self.plan.layout.prelude, v) {
                continue;
            }
            match p.op(v) {
                Op::Proj(..) => {}
                Op::If { cond, then_, else_ } => {
                    let c = self.arg(*cond);
                    self.check()?;
                    line(out, depth, &format!("if ({c}) {{"));
                    for (arm, last) in [(then_, false), (else_, true)] {
                        self.structured(out, depth + 1, arm)?;
                        for (pv, k) in self.projs(v) {
                            let Some(y) = arm.yields.get(k as usize) else {
                                continue;
                            };
                            let e = self.arg(*y);
                            line(out, depth + 1, &format!("{} = {e};", self.name(pv)));
                        }
                        self.check()?;
                        line(out, depth, if last { "}" } else { "} else {" });
                    }
                }
                Op::Illuminance { .. } | Op::Trace { .. } | Op::Occlusion { .. } => {
                    return Err(self.unsupported(
                        v,
                        "a light loop runs whole in one kernel: no host step or other light \
                         loop inside it"
                            .into(),
                    ));
                }
                _ => {
                    let e = keep(p.ty(v), &self.value_expr(v)?);
                    line(out, depth, &format!("{} = {e};", self.name(v)));
                }
            }
        }
        Ok(())
    }

    /// The `let` loading a stream, parameter or prelude value, or a float constant behind
    /// the value barrier.
    fn remat_load(&self, v: Value) -> Result<String, BackendError> {
        if let Op::Const(c) = self.p.op(v)
            && let Some(e) = kept_const(c)
        {
            return Ok(format!("let {} = {e};", self.name(v)));
        }
        let ty = self.p.ty(v);
        let n = emit::columns(ty);
        let cols: Vec<String> = if let Some(&s) = self.plan.layout.prelude.get(&v.index()) {
            (0..n).map(|c| format!("sn_uni[{}u]", s + c)).collect()
        } else {
            match self.p.op(v) {
                Op::Param(i) => {
                    let Some(&s) = self.plan.layout.params.get(i) else {
                        return Err(self.codegen(format!("parameter {i} has no uniform slot")));
                    };
                    (0..n).map(|c| format!("sn_uni[{}u]", s + c)).collect()
                }
                Op::Stream(st) => {
                    let Some(&(_, s)) = self.plan.layout.streams.iter().find(|x| x.0 == *st) else {
                        return Err(self.codegen(format!(
                            "stream {} is not in the fragment buffer",
                            st.name()
                        )));
                    };
                    (0..n).map(|c| col("sn_frag", s + c)).collect()
                }
                _ => return Err(self.codegen("not a load".into())),
            }
        };
        Ok(format!(
            "let {} = {};",
            self.name(v),
            emit::load_columns(ty, &cols)
        ))
    }

    /// The `let` loading a value of an earlier step from `sn_tmp`.
    fn tmp_load(&self, v: Value) -> Result<String, BackendError> {
        let Some(c) = self.plan.layout.tmp.get(v.index()).copied().flatten() else {
            return Err(self.codegen(format!(
                "it reads {} ({}), which no earlier step stored",
                value_name(&self.plan.names, v),
                self.p.op(v).short_name()
            )));
        };
        let ty = self.p.ty(v);
        let cols: Vec<String> = (0..emit::columns(ty))
            .map(|k| col("sn_tmp", c + k))
            .collect();
        Ok(format!(
            "let {} = {};",
            self.name(v),
            emit::load_columns(ty, &cols)
        ))
    }
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
    let mut w = Writer {
        p,
        plan,
        pass_no,
        outputs: pass.outputs.clone(),
        locals: HashSet::new(),
        remat: BTreeSet::new(),
        loads: BTreeSet::new(),
        in_loop: false,
        uses_mask: false,
        uses_ambient: false,
        uses_xf: false,
        uses_textures: false,
        err: None,
    };
    let remat = |v: Value| is_remat(p, &plan.layout.prelude, v);
    let mut locals: Vec<Value> = Vec::new();
    for it in &pass.items {
        match &it.kind {
            ItemKind::Value(v) => locals.push(*v),
            ItemKind::Merge(r) => locals.extend(w.projs(*r).into_iter().map(|x| x.0)),
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
    w.locals = locals.iter().copied().collect();

    // The pass's guard (an early return), then the items under their remaining guards.
    let prefix = pass.guard.len();
    let mut guard_expr = Vec::new();
    for &(c, pol) in &pass.guard {
        let e = w.arg(c);
        guard_expr.push(if pol { e } else { format!("!({e})") });
    }
    w.check()?;
    let (pre_remat, pre_loads) = (w.remat.clone(), w.loads.clone());

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

    // Assemble: the entry point first, then what it needs of the libraries.
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
    for &v in &pre_remat {
        line(&mut s, 1, &w.remat_load(v)?);
    }
    for &v in &pre_loads {
        line(&mut s, 1, &w.tmp_load(v)?);
    }
    if !guard_expr.is_empty() {
        line(
            &mut s,
            1,
            &format!("if (!({})) {{", guard_expr.join(" && ")),
        );
        line(&mut s, 2, "return;");
        line(&mut s, 1, "}");
    }
    for &v in w.remat.difference(&pre_remat) {
        line(&mut s, 1, &w.remat_load(v)?);
    }
    for &v in w.loads.difference(&pre_loads) {
        line(&mut s, 1, &w.tmp_load(v)?);
    }
    for &v in &locals {
        let t = w.wgsl_type(v)?;
        line(&mut s, 1, &format!("var {}: {t};", w.name(v)));
    }
    s.push_str(&body);
    s.push_str("}\n");
    let entry = s;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "// shadenet: material `{}`, pass {pass_no}",
        p.name.replace(['\n', '\r'], " ")
    );
    s.push_str(&library_for(emit::library(), &format!("{extra}{entry}")));
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
    s.push_str(&extra);
    s.push_str(&entry);
    Ok(KernelText {
        wgsl: s,
        textures: w.uses_textures,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_library_splits_into_declarations() {
        let (_, items) = library_items(emit::library()).expect("lib.wgsl splits");
        assert!(items.iter().any(|i| i.name == "sn_sqrt"));
        let (_, tex) = library_items(emit::TEXTURE_LIBRARY).expect("texture.wgsl splits");
        assert!(tex.iter().any(|i| i.name == "sn_texture"));
    }

    #[test]
    fn only_the_declarations_a_kernel_needs_are_included() {
        let lib = "// head\nconst SN_T = array<f32, 2>(1.0f, 2.0f);\n\
                   fn sn_a(x: f32) -> f32 {\n    return x * SN_T[0];\n}\n\
                   fn sn_b(x: f32) -> f32 {\n    return sn_a(x);\n}\n\
                   // unused\nfn sn_c(x: f32) -> f32 {\n    return x;\n}\n";
        let out = library_for(lib, "fn main() { let y = sn_b(1.0f); }");
        assert!(out.contains("fn sn_a") && out.contains("fn sn_b") && out.contains("SN_T"));
        assert!(!out.contains("fn sn_c"), "{out}");
        // Code outside declarations: the whole library.
        assert_eq!(
            library_for("let x = 1;\nfn sn_a() {}\n", "sn_a"),
            "let x = 1;\nfn sn_a() {}\n"
        );
    }
}
