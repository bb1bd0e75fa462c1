//! Loop unrolling: a loop whose trip count is a compile-time constant becomes that many
//! copies of its body, one after the other, in the block that held it.
//!
//! **When.** The pass simulates the loop at compile time on the carried values the
//! condition depends on: starting from the initial values (each evaluated through
//! constants, folding as [`super::fold`] folds, in f32), it evaluates the condition, and
//! while it holds, the body's next values of those carried values. Values that are not
//! constants (a sum of shading inputs, say) may be carried along as long as the condition
//! never needs them. The loop is unrolled when the condition becomes false after at most
//! [`MAX_TRIPS`] iterations and the copies add at most [`MAX_OPS`] ops (body ops × trips);
//! otherwise — a varying or unknown trip count, a long loop, one that would meet the
//! iteration limit — it stays a loop. The budget keeps compile time and kernel size in
//! check (lavapipe compiles long straight-line kernels slowly).
//!
//! **How.** Iteration `i`'s copy reads iteration `i − 1`'s yields where the body read
//! `loop.var`s (the initial values for the first); the loop's results become the last
//! copy's yields (the initial values for a loop that never runs). Regions inside the body
//! are copied whole; `loop.var`s of a nested loop stay that loop's. The copies are the very
//! ops the loop would have run in the same order, so results are bit-identical; the fold,
//! CSE and DCE rounds that follow simplify them.
//!
//! The pass returns the number of loops it unrolled.

use super::Specialization;
use super::fold::fold_consts;
use crate::ir::{Block, Expr, LOOP_ITERATION_LIMIT, Op, Program, Value};
use crate::types::ConstValue;
use std::collections::{HashMap, HashSet};

/// The most iterations a loop is unrolled to.
pub const MAX_TRIPS: usize = 64;

/// The most ops the copies of one loop's body may add.
pub const MAX_OPS: usize = 4096;

/// How deep the constant evaluator follows operands.
const MAX_DEPTH: usize = 256;

/// Unrolls every loop with a constant trip count within the budget; returns how many.
pub fn run(p: &mut Program, _spec: &Specialization) -> usize {
    let mut map: Vec<Option<Value>> = vec![None; p.exprs.len()];
    let mut body = std::mem::take(&mut p.body);
    let mut gone = HashSet::new();
    let n = unroll_block(p, &mut body, &mut map, &mut gone);
    p.body = body;
    if n > 0 {
        map.resize(p.exprs.len(), None);
        p.substitute(&map);
    }
    n
}

/// Unrolls the loops of `block` and of the regions nested in it; `gone` holds the unrolled
/// loops, whose `proj`s leave with them (their uses read the copies' yields, via `map`).
fn unroll_block(
    p: &mut Program,
    block: &mut Block,
    map: &mut Vec<Option<Value>>,
    gone: &mut HashSet<Value>,
) -> usize {
    let mut n = 0;
    let mut out = Vec::with_capacity(block.body.len());
    for v in std::mem::take(&mut block.body) {
        if let Op::Proj(r, _) = p.exprs[v.index()].op
            && gone.contains(&r)
        {
            continue;
        }
        // Inner regions first: an inner loop unrolled may make the outer one cheaper.
        n += p.rewrite_blocks(v, |p, b| unroll_block(p, b, map, gone));
        let Op::Loop { init, cond, body } = &p.exprs[v.index()].op else {
            out.push(v);
            continue;
        };
        let Some(trips) = trip_count(p, init, cond, body) else {
            out.push(v);
            continue;
        };
        let (init, body) = (init.clone(), body.clone());
        let mut cur = init;
        for _ in 0..trips {
            cur = copy_iteration(p, (&body, map), &cur, &mut out);
        }
        map.resize(p.exprs.len(), None);
        for (i, e) in p.exprs.iter().enumerate() {
            if let Op::Proj(r, k) = e.op
                && r == v
            {
                map[i] = cur.get(k as usize).copied();
            }
        }
        gone.insert(v);
        n += 1;
    }
    block.body = out;
    n
}

/// The loop's trip count if the condition is a constant at every iteration and the
/// unrolled copies fit the budget.
fn trip_count(p: &Program, init: &[Value], cond: &Block, body: &Block) -> Option<usize> {
    let size = ops_in(p, body);
    let ceiling = MAX_TRIPS.min(MAX_OPS / size.max(1));
    // The loop's own `loop.var`s (not those of loops nested in it).
    let mut vars: HashMap<Value, usize> = HashMap::new();
    for b in [cond, body] {
        own_loop_vars(p, b, &mut vars);
    }
    let mut memo = HashMap::new();
    let mut env: Vec<Option<ConstValue>> = init
        .iter()
        .map(|v| eval(p, *v, &HashMap::new(), &[], &mut memo, 0))
        .collect();
    for trips in 0..=ceiling.min(LOOP_ITERATION_LIMIT as usize) {
        let mut memo = HashMap::new();
        let c = eval(p, *cond.yields.first()?, &vars, &env, &mut memo, 0)?;
        match c {
            ConstValue::Bool(false) => return Some(trips),
            ConstValue::Bool(true) if trips < ceiling => {}
            _ => return None,
        }
        env = body
            .yields
            .iter()
            .map(|y| eval(p, *y, &vars, &env, &mut memo, 0))
            .collect();
    }
    None
}

/// The `loop.var`s listed in `block` and its nested `if` arms and light loops (not inside
/// nested loops), with their carried index.
fn own_loop_vars(p: &Program, block: &Block, out: &mut HashMap<Value, usize>) {
    for &v in &block.body {
        match p.op(v) {
            Op::LoopVar(k) => {
                out.insert(v, *k as usize);
            }
            Op::Loop { .. } => {}
            op => {
                for b in op.blocks() {
                    own_loop_vars(p, b, out);
                }
            }
        }
    }
}

/// Ops in a block, nested blocks included.
fn ops_in(p: &Program, block: &Block) -> usize {
    let mut n = 0;
    p.walk(block, &mut |_| n += 1);
    n
}

/// The constant `v` evaluates to, with the loop's `loop.var`s (`vars`, by carried index)
/// at `env`'s values; `None` where it depends on anything else.
fn eval(
    p: &Program,
    v: Value,
    vars: &HashMap<Value, usize>,
    env: &[Option<ConstValue>],
    memo: &mut HashMap<Value, Option<ConstValue>>,
    depth: usize,
) -> Option<ConstValue> {
    if let Some(c) = memo.get(&v) {
        return c.clone();
    }
    if depth > MAX_DEPTH {
        return None;
    }
    let e = p.exprs.get(v.index())?;
    let c = match &e.op {
        Op::Const(c) => Some(c.clone()),
        Op::LoopVar(_) => vars.get(&v).and_then(|k| env.get(*k).cloned().flatten()),
        op if op.is_pure() => {
            let mut operands = Vec::new();
            e.op.for_each_operand(|o| operands.push(o));
            let mut consts = Vec::with_capacity(operands.len());
            for o in operands {
                consts.push(eval(p, o, vars, env, memo, depth + 1)?);
            }
            let refs: Vec<&ConstValue> = consts.iter().collect();
            fold_consts(&e.op, e.ty?, &refs)
        }
        _ => None,
    };
    memo.insert(v, c.clone());
    c
}

/// Appends to `out` a copy of one iteration of `body` reading `cur` for its `loop.var`s;
/// returns the copy's yields (the next carried values). `map` holds the `proj`s of loops
/// already unrolled inside the body (their uses read the copies' yields): the copy reads
/// those instead.
fn copy_iteration(
    p: &mut Program,
    (body, map): (&Block, &[Option<Value>]),
    cur: &[Value],
    out: &mut Vec<Value>,
) -> Vec<Value> {
    let mut rename: HashMap<Value, Value> = HashMap::new();
    let copied = copy_block(p, body, (cur, map), &mut rename, true);
    out.extend(copied.body);
    copied.yields
}

/// A copy of `block` with fresh values; `own` while the `loop.var`s met are the unrolled
/// loop's (they become `cur`'s values instead of copies).
fn copy_block(
    p: &mut Program,
    block: &Block,
    (cur, map): (&[Value], &[Option<Value>]),
    rename: &mut HashMap<Value, Value>,
    own: bool,
) -> Block {
    // A `proj` of an inner loop unrolled before reads that loop's last copy's yield.
    let resolve = |v: Value, rename: &HashMap<Value, Value>| {
        let mut r = v;
        for _ in 0..map.len() {
            match map.get(r.index()).copied().flatten() {
                Some(m) if m != r => r = m,
                _ => break,
            }
        }
        rename.get(&r).copied().unwrap_or(r)
    };
    let mut body = Vec::with_capacity(block.body.len());
    for &v in &block.body {
        let e = p.exprs[v.index()].clone();
        if let (true, Op::LoopVar(k)) = (own, &e.op)
            && let Some(c) = cur.get(*k as usize)
        {
            rename.insert(v, *c);
            continue;
        }
        let inner_own = own && !matches!(e.op, Op::Loop { .. });
        let mut op = e.op;
        for o in op.operands_mut() {
            *o = resolve(*o, rename);
        }
        let blocks: Vec<Block> = op.blocks_mut().into_iter().map(std::mem::take).collect();
        let copies: Vec<Block> = blocks
            .iter()
            .map(|b| copy_block(p, b, (cur, map), rename, inner_own))
            .collect();
        for (slot, b) in op.blocks_mut().into_iter().zip(copies) {
            *slot = b;
        }
        let c = p.add_expr(Expr { op, ty: e.ty });
        rename.insert(v, c);
        body.push(c);
    }
    let yields = block.yields.iter().map(|y| resolve(*y, rename)).collect();
    Block { body, yields }
}
