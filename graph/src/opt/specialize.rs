//! Specialization: what is fixed for this compile becomes constant.
//!
//! - Baking (instance compilation, `Specialization::bake`): every `param i` becomes the
//!   constant `params[i].default` (the parameter table is kept, unused, for the record).
//! - Components: `component_enabled k` becomes `true` or `false` from the active mask.
//! - Ray types: the `raytype` stream becomes a constant when the material sees one ray type
//!   only, and `eq`/`ne` tests of it against a constant ray type the material never sees
//!   become `false`/`true`.
//!
//! The later passes (fold, dead branch, DCE) then remove what the constants make dead.

use super::Specialization;
use crate::ir::{BinOp, Op, Program, Stream};
use crate::types::ConstValue;

/// Runs the specialization; returns the number of ops replaced by constants.
pub fn run(p: &mut Program, spec: &Specialization) -> usize {
    let mut changes = 0;
    let single_ray = (spec.ray_types.count_ones() == 1).then_some(spec.ray_types as i32);
    for i in 0..p.exprs.len() {
        let new = match &p.exprs[i].op {
            Op::Param(k) if spec.bake => p.params.get(*k as usize).map(|d| d.default.clone()),
            Op::ComponentEnabled(k) if spec.passes.specialize => Some(ConstValue::Bool(
                spec.components & (1u32 << (*k as u32 & 31)) != 0,
            )),
            Op::Stream(Stream::RayType) if spec.passes.specialize => {
                single_ray.map(ConstValue::Int)
            }
            Op::Binary(op @ (BinOp::Eq | BinOp::Ne), a, b) if spec.passes.specialize => {
                let ray = |x: &crate::ir::Value| matches!(p.op(*x), Op::Stream(Stream::RayType));
                let konst = |x: &crate::ir::Value| match p.op(*x) {
                    Op::Const(ConstValue::Int(k)) => Some(*k),
                    _ => None,
                };
                let k = if ray(a) {
                    konst(b)
                } else if ray(b) {
                    konst(a)
                } else {
                    None
                };
                // A ray type the material never sees: the test is decided.
                k.filter(|k| (*k as u32) & spec.ray_types == 0 && k.count_ones() == 1)
                    .map(|_| ConstValue::Bool(*op == BinOp::Ne))
            }
            _ => None,
        };
        if let Some(c) = new {
            p.exprs[i].op = Op::Const(c);
            changes += 1;
        }
    }
    changes
}
