//! Lowering of [`Op::Loop`](shadenet_graph::ir::Op::Loop): one CLIF loop per IR loop, in the
//! scalar and the batch mode, never unrolled.
//!
//! The carried values live in `Variable`s (one per component) that the header block reads
//! and the body's end redefines; `loop.var k` is component group `k` of the values the
//! header read (the innermost loop's, kept in `Lowerer::loops`). The iteration budget is
//! one per loop *nest*: an outermost loop sets `budget = LOOP_ITERATION_LIMIT` when it
//! starts, and every body run of it or of a loop nested in it takes one (the interpreter's
//! rule, `runtime/src/interp.rs`). Blocks, in the scalar mode:
//!
//! ```text
//! header: cur = carried; run cond → c;     c ? check : exit
//! check:  budget == 0 ?                    limit : body
//! limit:  ctx.loop_limits += 1;            exit
//! body:   budget -= 1; run body → ys; carried = ys; header
//! exit:   results = carried
//! ```
//!
//! The interpreter's order exactly: the condition runs before every iteration, and the
//! budget is checked only where the condition still holds (a loop whose condition fails
//! just as the budget runs out is not counted).
//!
//! The batch mode runs the four lanes in lockstep: a running mask (starting as the active
//! mask of the enclosing arm, all lanes at top level) narrows to `run & cond` at every
//! header, the loop leaves when no lane runs, the body runs with that mask as the active
//! mask of its nested conditionals, and its yields are blended into the carried values only
//! for the lanes still running (`bitselect`): a lane that has left keeps its values. The
//! budget is per lane (`i32x4`; inner loops run different counts per lane): lanes of the
//! running mask whose budget is spent stop, and those that hold fragments (below the
//! packet's count, as the guard counts) are added to the count (`popcnt` of the mask's sign
//! bits); the others run the body and pay one iteration. Inactive and padding lanes count
//! nothing.
//!
//! Loads of immutable memory first made in the condition (the header, which dominates the
//! body and the exit) are reused by the body; the body's own loads stay in its scope.

use super::{Kind, Lowerer, R, comps, flags, kind};
use crate::abi::ctx_offset;
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::types::{I8, I32, I32X4};
use cranelift_codegen::ir::{InstBuilder, Value as V};
use cranelift_frontend::Variable;
use shadenet_graph::ir::{Block, LOOP_ITERATION_LIMIT, Value};

impl Lowerer<'_, '_> {
    /// Lowers the loop `v` (see the module documentation); returns its results, per
    /// carried value its components.
    pub(super) fn loop_(
        &mut self,
        v: Value,
        init: &[Value],
        cond: &Block,
        body: &Block,
    ) -> R<Vec<Vec<V>>> {
        let mut ks: Vec<(Kind, usize)> = Vec::new();
        let mut vars: Vec<Variable> = Vec::new();
        for a in init {
            let t = self.ty(*a);
            let k = kind(t);
            ks.push((k, comps(t)));
            for x in self.get(*a)? {
                let var = self.b.declare_var(self.clif_ty(k));
                self.b.def_var(var, x);
                vars.push(var);
            }
        }
        // The nest's budget: set when an outermost loop starts, shared by the loops in it.
        let budget = match (self.loops.is_empty(), self.budget) {
            (false, Some(b)) => b,
            _ => {
                let ty = if self.batch() { I32X4 } else { I32 };
                let var = self.b.declare_var(ty);
                let full = self.b.ins().iconst(I32, i64::from(LOOP_ITERATION_LIMIT));
                let full = if self.batch() {
                    self.b.ins().splat(I32X4, full)
                } else {
                    full
                };
                self.b.def_var(var, full);
                self.budget = Some(var);
                var
            }
        };
        // Batch: the lanes still running (those of the enclosing arm at first).
        let run_var = if self.batch() {
            let var = self.b.declare_var(I32X4);
            let all = match self.active {
                Some(a) => a,
                None => self.bconst(true),
            };
            self.b.def_var(var, all);
            Some(var)
        } else {
            None
        };
        // The lanes that run the body this iteration (scalar: whether the fragment does).
        let go_var = self.b.declare_var(if self.batch() { I32X4 } else { I8 });
        let header = self.b.create_block();
        let check = self.b.create_block();
        let limit = self.b.create_block();
        let body_blk = self.b.create_block();
        let exit = self.b.create_block();
        self.b.ins().jump(header, &[]);

        self.b.switch_to_block(header);
        let cur: Vec<V> = vars.iter().map(|x| self.b.use_var(*x)).collect();
        self.loops.push(Self::regroup(&ks, &cur));
        self.push_scope();
        let outer = self.active;
        let run = run_var.map(|r| self.b.use_var(r));
        if run.is_some() {
            self.active = run;
        }
        self.block(cond)?;
        let Some(&c) = cond.yields.first() else {
            return Err(self.unsupported(v, "a loop condition without a yield"));
        };
        let c = self.get(c)?[0];
        // The lanes (scalar: the fragment) that go on: condition true (and still running).
        let go = match run {
            Some(r) => {
                let go = self.b.ins().band(r, c);
                let any = self.b.ins().vany_true(go);
                self.b.ins().brif(any, check, &[], exit, &[]);
                go
            }
            None => {
                self.b.ins().brif(c, check, &[], exit, &[]);
                c
            }
        };

        // Lanes whose nest has no iteration left stop here (counted).
        self.b.switch_to_block(check);
        let left = self.b.use_var(budget);
        self.b.def_var(go_var, go);
        let stop = if self.batch() {
            let zero = self.b.ins().iconst(I32, 0);
            let zero = self.b.ins().splat(I32X4, zero);
            let spent = self.b.ins().icmp(IntCC::Equal, left, zero);
            let stop = self.b.ins().band(go, spent);
            let any = self.b.ins().vany_true(stop);
            self.b.ins().brif(any, limit, &[], body_blk, &[]);
            stop
        } else {
            let spent = self.b.ins().icmp_imm_s(IntCC::Equal, left, 0);
            self.b.ins().brif(spent, limit, &[], body_blk, &[]);
            go
        };

        self.b.switch_to_block(limit);
        self.count_loop_limit(stop);
        if self.batch() {
            let on = self.b.ins().band_not(go, stop);
            self.b.def_var(go_var, on);
            let any = self.b.ins().vany_true(on);
            self.b.ins().brif(any, body_blk, &[], exit, &[]);
        } else {
            self.b.ins().jump(exit, &[]);
        }

        self.b.switch_to_block(body_blk);
        let go = self.b.use_var(go_var);
        if run.is_some() {
            self.active = Some(go);
        }
        // One iteration less for the lanes that run it (a lane mask is −1 where set).
        let left = self.b.use_var(budget);
        let left = if self.batch() {
            self.b.ins().iadd(left, go)
        } else {
            self.b.ins().iadd_imm_s(left, -1)
        };
        self.b.def_var(budget, left);
        self.push_scope();
        self.block(body)?;
        let ys = self.yields(body)?;
        self.pop_scope();
        for ((var, y), c) in vars.iter().zip(ys).zip(&cur) {
            let next = if run.is_some() {
                self.sel(go, y, *c)
            } else {
                y
            };
            self.b.def_var(*var, next);
        }
        if let Some(r) = run_var {
            self.b.def_var(r, go);
        }
        self.b.ins().jump(header, &[]);

        self.b.switch_to_block(exit);
        self.active = outer;
        self.pop_scope();
        self.loops.pop();
        let res: Vec<V> = vars.iter().map(|x| self.b.use_var(*x)).collect();
        Ok(Self::regroup(&ks, &res))
    }

    /// Adds the loop executions stopping at the limit to `CallCtx::loop_limits`: one
    /// (scalar), or the lanes of `go` that hold fragments (batch).
    fn count_loop_limit(&mut self, go: V) {
        let stopped = if self.batch() {
            let go = match self.left {
                Some(left) => {
                    let real = self.real_lanes(left);
                    self.b.ins().band(go, real)
                }
                None => go,
            };
            let bits = self.b.ins().vhigh_bits(I32, go);
            self.b.ins().popcnt(bits)
        } else {
            self.b.ins().iconst(I32, 1)
        };
        let at = ctx_offset::LOOP_LIMITS;
        let total = self.b.ins().load(I32, flags(), self.ctx, at);
        let total = self.b.ins().iadd(total, stopped);
        self.b.ins().store(flags(), total, self.ctx, at);
    }
}
