//! Dead code elimination: removes every value no output needs.
//!
//! Liveness flows backwards from the outputs: a live value makes its operands live; a live
//! region (one whose results some live `proj` reads) makes its condition or point and every
//! yield of its blocks live. A region none of whose results is read is removed whole, with
//! its blocks. Prelude values stay only if the body still reads them.

use super::Specialization;
use crate::ir::{Block, Program};

/// Removes dead values; returns how many were removed.
pub fn run(p: &mut Program, _spec: &Specialization) -> usize {
    let before = p.op_count();
    let mut live = vec![false; p.exprs.len()];
    for o in &p.outputs {
        live[o.value.index()] = true;
    }
    mark(p, &p.body, &mut live);
    mark(p, &p.prelude, &mut live);
    for e in &mut p.exprs {
        for b in e.op.blocks_mut() {
            b.body.retain(|v| live[v.index()]);
        }
    }
    p.body.body.retain(|v| live[v.index()]);
    p.prelude.body.retain(|v| live[v.index()]);
    before - p.op_count()
}

fn mark(p: &Program, block: &Block, live: &mut [bool]) {
    for y in &block.yields {
        live[y.index()] = true;
    }
    for &v in block.body.iter().rev() {
        if !live[v.index()] {
            continue;
        }
        let op = p.op(v);
        op.for_each_operand(|a| live[a.index()] = true);
        for inner in op.blocks() {
            mark(p, inner, live);
        }
    }
}
