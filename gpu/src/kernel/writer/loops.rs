//! Loops (`Op::Loop`) as structured WGSL inside one kernel.
//!
//! Owns: the carried values as `var`s set from `init`, the WGSL `loop` around the condition
//! block (a `break` where it yields false), the loop nest's iteration budget (a count of
//! body runs set to 0 by each execution of an outermost loop and shared by the loops nested
//! in it; a `break` where it reached `LOOP_ITERATION_LIMIT`, else one body run adds one, as
//! the interpreter's `run_loop`), the body block and the carried values' update from its yields,
//! `loop.var` (the innermost loop's `var`), and the loop's `proj`s. Must not touch: the blocks' other values ([`super::Writer`] writes
//! them), the stores of results ([`super`]), whether a loop may run on the GPU at all
//! ([`crate::planner`] refuses host steps and light loops inside one).

use super::{Writer, keep, line};
use shadenet_graph::ir::{Block, LOOP_ITERATION_LIMIT, Op, Value};
use shadenet_runtime::BackendError;

impl Writer<'_> {
    /// The WGSL name of carried value `k` of the loop whose WGSL name is `r`.
    fn carried(r: &str, k: usize) -> String {
        format!("sn_lv_{r}_{k}")
    }

    /// The statements of the loop `region` at indentation `depth`, its `proj`s assigned
    /// after it (not stored: the caller stores what a later step reads).
    pub(super) fn loop_region(
        &mut self,
        out: &mut String,
        depth: usize,
        region: Value,
    ) -> Result<(), BackendError> {
        let Op::Loop { init, cond, body } = self.p.op(region) else {
            return Err(self.codegen("a loop of a value that is not one".into()));
        };
        let r = self.name(region);
        for (k, x) in init.iter().enumerate() {
            let t = self.wgsl_type(*x)?;
            let e = self.arg(*x);
            let name = Self::carried(&r, k);
            line(out, depth, &format!("var {name}: {t} = {e};"));
        }
        self.check()?;
        // The nest's budget: started by the outermost loop, shared by the loops inside it.
        let outer = *self.loops.first().unwrap_or(&region);
        let budget = format!("sn_budget_{}", self.name(outer));
        if self.loops.is_empty() {
            line(out, depth, &format!("var {budget} = 0u;"));
        }
        line(out, depth, "loop {");
        self.loops.push(region);
        let res = self.loop_blocks(out, depth + 1, (&r, &budget), cond, body);
        self.loops.pop();
        res?;
        line(out, depth, "}");
        for (pv, k) in self.projs(region) {
            let e = Self::carried(&r, k as usize);
            line(out, depth, &format!("{} = {e};", self.name(pv)));
        }
        Ok(())
    }

    /// The inside of the WGSL `loop` of loop `r` (its nest's budget `budget`): the
    /// condition, the two stops, the budget taken, the body and the carried values' update.
    fn loop_blocks(
        &mut self,
        out: &mut String,
        d: usize,
        (r, budget): (&str, &str),
        cond: &Block,
        body: &Block,
    ) -> Result<(), BackendError> {
        self.structured(out, d, cond)?;
        let Some(&c) = cond.yields.first() else {
            return Err(self.codegen(format!("the loop {r} has a condition without a value")));
        };
        let c = self.arg(c);
        self.check()?;
        line(out, d, &format!("if (!({c})) {{ break; }}"));
        line(
            out,
            d,
            &format!("if ({budget} == {LOOP_ITERATION_LIMIT}u) {{ break; }}"),
        );
        line(out, d, &format!("{budget} = {budget} + 1u;"));
        self.structured(out, d, body)?;
        // Every yield is read before any carried value changes (a yield may be a `loop.var`
        // value, but those are copies in their own `var`s).
        let ys: Vec<String> = body.yields.iter().map(|y| self.arg(*y)).collect();
        self.check()?;
        for (k, y) in ys.into_iter().enumerate() {
            line(out, d, &format!("{} = {y};", Self::carried(r, k)));
        }
        Ok(())
    }

    /// The statement of `loop.var k` (value `v`): a copy of the innermost loop's carried
    /// value, behind the value barrier.
    pub(super) fn loop_var(
        &mut self,
        out: &mut String,
        depth: usize,
        v: Value,
        k: u8,
    ) -> Result<(), BackendError> {
        let Some(&region) = self.loops.last() else {
            return Err(self.codegen(format!(
                "{} reads a loop variable outside a loop",
                self.name(v)
            )));
        };
        let e = keep(self.p.ty(v), &Self::carried(&self.name(region), k as usize));
        line(out, depth, &format!("{} = {e};", self.name(v)));
        Ok(())
    }
}
