//! The kernel's own code, value by value: [`Writer`] turns the items of one pass into WGSL
//! statements (see [`super`] for what a kernel contains).
//!
//! Owns: the WGSL names of values, operands (streams, parameters and prelude values loaded
//! once; constants; the mask, ambient light and light sample; values of earlier steps from
//! `sn_tmp`), the value barrier ([`keep`]), the ops that are not pure (`transform`,
//! `texture`), items (values, merges, light loops, loops: `loops`), the structured blocks
//! inside a light loop or loop, and the stores of crossing values and outputs. Must not
//! touch: the order of a kernel's parts and its bindings ([`super`]), the included library
//! ([`super::library`]), the WGSL of pure ops ([`crate::emit`]).

mod loops;

use crate::emit;
use crate::plan::{
    ItemKind, LIGHT_COLUMNS, Plan, U_CAMERA, U_CAMERA_INV, U_OBJECT, U_OBJECT_INV, is_remat,
    value_name,
};
use shadenet_graph::ir::{Block, Op, Program, Space, Value, XformKind};
use shadenet_graph::types::{ConstValue, Type};
use shadenet_runtime::BackendError;
use std::collections::{BTreeSet, HashSet};

/// The matrices' uniform slots for a transform helper: the matrix a point or vector is
/// multiplied by, and the one whose transpose a normal is multiplied by.
fn space_slots(s: Space) -> Option<(usize, usize)> {
    match s {
        Space::World => None,
        Space::Camera => Some((U_CAMERA, U_CAMERA_INV)),
        Space::Object => Some((U_OBJECT, U_OBJECT_INV)),
    }
}

/// The state of writing one pass's kernel: what it has read and used so far.
pub(super) struct Writer<'a> {
    p: &'a Program,
    plan: &'a Plan,
    pass_no: usize,
    /// Outputs this pass writes (indices into `Program::outputs`).
    outputs: Vec<usize>,
    /// Values assigned by this kernel (declared as `var`s).
    pub(super) locals: HashSet<Value>,
    /// Streams, parameters and prelude values read (loaded once, as `let`s).
    pub(super) remat: BTreeSet<Value>,
    /// Values of earlier steps read (loaded from `sn_tmp`).
    pub(super) loads: BTreeSet<Value>,
    /// Whether the code being written is inside a light loop (the light sample is in scope).
    in_loop: bool,
    /// The loops whose blocks are being written, innermost last (`loop.var` reads the last).
    loops: Vec<Value>,
    /// Whether some operand reads the component mask (`sn_mask`).
    pub(super) uses_mask: bool,
    /// Whether some operand reads the ambient light (`sn_ambient`).
    pub(super) uses_ambient: bool,
    /// Whether some value calls a transform helper.
    pub(super) uses_xf: bool,
    /// Whether some value reads a texture.
    pub(super) uses_textures: bool,
    /// The first error met inside an operand callback.
    err: Option<BackendError>,
}

/// The column `c` of buffer `buf` for this invocation's fragment.
pub(super) fn col(buf: &str, c: usize) -> String {
    format!("{buf}[{c}u * n + i]")
}

/// Appends `text` as one line indented `depth` levels.
pub(super) fn line(out: &mut String, depth: usize, text: &str) {
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
        Type::Vec4 | Type::Color4 => {
            format!("bitcast<vec4<f32>>(bitcast<vec4<u32>>({e}) ^ vec4<u32>({k}))")
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
        ConstValue::Vec4(v) | ConstValue::Color4(v) => {
            keep(Type::Vec4, &format!("vec4<f32>({})", row(v)))
        }
        ConstValue::Matrix33(_) | ConstValue::Matrix44(_) => {
            let k = c.ty().matrix_size();
            let rows: Vec<String> = c
                .floats()
                .chunks(k)
                .map(|r| {
                    format!(
                        "bitcast<vec{k}<f32>>(bitcast<vec{k}<u32>>(vec{k}<f32>({})) ^ vec{k}<u32>({}))",
                        row(r),
                        emit::KEY
                    )
                })
                .collect();
            format!("array<vec{k}<f32>, {k}>({})", rows.join(", "))
        }
        _ => return None,
    })
}

/// Whether WGSL's `select` takes values of this type (scalars and vectors; not arrays).
fn selectable(ty: Type) -> bool {
    !ty.is_matrix()
}

impl<'a> Writer<'a> {
    /// A writer for pass number `pass_no` of `plan`, which writes the outputs `outputs`.
    pub(super) fn new(
        p: &'a Program,
        plan: &'a Plan,
        pass_no: usize,
        outputs: Vec<usize>,
    ) -> Writer<'a> {
        Writer {
            p,
            plan,
            pass_no,
            outputs,
            locals: HashSet::new(),
            remat: BTreeSet::new(),
            loads: BTreeSet::new(),
            in_loop: false,
            loops: Vec::new(),
            uses_mask: false,
            uses_ambient: false,
            uses_xf: false,
            uses_textures: false,
            err: None,
        }
    }
}

impl Writer<'_> {
    /// The WGSL name of a value (`vN` after the printer's `%N`).
    pub(super) fn name(&self, v: Value) -> String {
        match self.plan.names.get(v.index()).copied().flatten() {
            Some(n) => format!("v{n}"),
            None => format!("x{}", v.index()),
        }
    }

    /// [`BackendError::Unsupported`] for value `v`.
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

    /// [`BackendError::Codegen`] for this pass (a back-end bug).
    pub(super) fn codegen(&self, message: String) -> BackendError {
        BackendError::Codegen {
            backend: "gpu",
            material: self.p.name.clone(),
            message: format!("pass {}: {message}", self.pass_no),
        }
    }

    /// The WGSL type of a value.
    pub(super) fn wgsl_type(&self, v: Value) -> Result<&'static str, BackendError> {
        let ty = self.p.ty(v);
        emit::wgsl_type(ty).map_err(|e| self.unsupported(v, e.to_string()))
    }

    /// The `proj` users of a region as (value, result index).
    pub(super) fn projs(&self, region: Value) -> Vec<(Value, u8)> {
        self.plan
            .projs
            .get(&region.index())
            .cloned()
            .unwrap_or_default()
    }

    /// The first error met inside an operand callback, if any.
    pub(super) fn check(&mut self) -> Result<(), BackendError> {
        match self.err.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// The WGSL expression of an operand.
    pub(super) fn arg(&mut self, v: Value) -> String {
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
            Op::LightPdf if self.in_loop => "sn_lpdf".into(),
            Op::LightL | Op::LightCl => "vec3<f32>()".into(),
            Op::LightVisible => "f32(1.0)".into(),
            Op::LightPdf => "f32(0.0)".into(),
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
            Op::Texture {
                texture,
                uv,
                derivs,
                sampling,
                alpha,
            } => {
                self.uses_textures = true;
                let uv = self.arg(*uv);
                let (dx, dy) = match derivs {
                    Some([dx, dy]) => (self.arg(*dx), self.arg(*dy)),
                    None => ("vec2<f32>(0.0f)".into(), "vec2<f32>(0.0f)".into()),
                };
                let sw = if *alpha { "w" } else { "xyz" };
                let bits = sampling.bits();
                format!("sn_texture({texture}u, {bits}u, {uv}, {dx}, {dy}).{sw}")
            }
            Op::Trace { .. }
            | Op::Occlusion { .. }
            | Op::Illuminance { .. }
            | Op::If { .. }
            | Op::Loop { .. }
            | Op::LoopVar(_) => {
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
    pub(super) fn output_store(&mut self, out: &mut String, depth: usize, k: usize, e: &str) {
        let slot = &self.plan.layout.outputs[k];
        let ty = slot.ty;
        let cols = if ty == Type::String {
            // The interpreter writes no floats for it: it stays 0.
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

    /// The statements of one item, at indentation `depth`.
    pub(super) fn item(
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
            ItemKind::Loop { region } => {
                self.loop_region(out, depth, *region)?;
                for (pv, _) in self.projs(*region) {
                    self.stores(out, depth, pv);
                }
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
                line(out, d, &format!("let sn_lpdf = {};", light(7)));
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

    /// A block inside a light loop or loop, as structured WGSL: an `if` runs only its taken
    /// arm, as in the interpreter; a loop is written whole (`loops`).
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
                Op::Loop { .. } => self.loop_region(out, depth, v)?,
                Op::LoopVar(k) => self.loop_var(out, depth, v, *k)?,
                Op::Illuminance { .. } | Op::Trace { .. } | Op::Occlusion { .. } => {
                    return Err(self.unsupported(
                        v,
                        "a light loop or loop runs whole in one kernel: no host step or light \
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
    pub(super) fn remat_load(&self, v: Value) -> Result<String, BackendError> {
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
    pub(super) fn tmp_load(&self, v: Value) -> Result<String, BackendError> {
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
