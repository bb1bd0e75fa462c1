//! Editing programs: the operations optimizer passes share.
//!
//! Passes rewrite blocks (remove, move or add values) and operands; these helpers keep the
//! invariants that matter between passes: every use is rewritten ([`Program::substitute`]),
//! and [`Program::compact`] drops the values no block lists any more, renumbers the arena in
//! evaluation order and removes unused textures.

use super::{Block, Expr, Op, Program, Value};

impl Op {
    /// Mutable references to every operand of this op (not values inside nested blocks).
    pub fn operands_mut(&mut self) -> Vec<&mut Value> {
        match self {
            Op::Const(_)
            | Op::Param(_)
            | Op::Stream(_)
            | Op::ComponentEnabled(_)
            | Op::LightL
            | Op::LightCl
            | Op::LightVisible
            | Op::LightPdf
            | Op::LoopVar(_)
            | Op::AttributeFound { .. }
            | Op::Ambient => Vec::new(),
            Op::Transform { arg, .. } => vec![arg],
            Op::Unary(_, a) | Op::Extract(a, _) | Op::Splat(a) | Op::Convert(a) => vec![a],
            Op::Binary(_, a, b) => vec![a, b],
            Op::Select { cond, a, b } => vec![cond, a, b],
            Op::Construct(args)
            | Op::Call(_, args)
            | Op::Loop { init: args, .. }
            | Op::Print { args, .. } => args.iter_mut().collect(),
            Op::If { cond, .. } => vec![cond],
            Op::Illuminance { p, .. } => vec![p],
            Op::Proj(r, _) => vec![r],
            Op::Attribute { default, .. } => vec![default],
            Op::Texture { uv, derivs, .. } => {
                let mut v = vec![uv];
                if let Some([dx, dy]) = derivs {
                    v.push(dx);
                    v.push(dy);
                }
                v
            }
            Op::Trace { dir, pdf, .. } => {
                let mut v = vec![dir];
                v.extend(pdf.as_mut());
                v
            }
            Op::Occlusion {
                n,
                samples,
                max_distance,
            } => vec![n, samples, max_distance],
            Op::Probe {
                origin,
                dir,
                min_distance,
                max_distance,
                ..
            } => vec![origin, dir, min_distance, max_distance],
        }
    }

    /// The nested blocks of a region op, mutably.
    pub fn blocks_mut(&mut self) -> Vec<&mut Block> {
        match self {
            Op::If { then_, else_, .. } => vec![then_, else_],
            Op::Illuminance { body, .. } => vec![body],
            Op::Loop { cond, body, .. } => vec![cond, body],
            _ => Vec::new(),
        }
    }

    /// Whether the op is a pure function of its operands' values alone (`Unary`, `Binary`,
    /// `Select`, `Construct`, `Extract`, `Splat`, `Convert`, `Call`): what constant folding
    /// evaluates, loop unrolling simulates and uniform hoisting may move. Every other op
    /// reads an input, the context, the scene or a region's state, or is a region.
    pub fn is_pure(&self) -> bool {
        match self {
            Op::Unary(..)
            | Op::Binary(..)
            | Op::Select { .. }
            | Op::Construct(_)
            | Op::Extract(..)
            | Op::Splat(_)
            | Op::Convert(_)
            | Op::Call(..) => true,
            Op::Const(_)
            | Op::Param(_)
            | Op::Stream(_)
            | Op::Transform { .. }
            | Op::ComponentEnabled(_)
            | Op::LightL
            | Op::LightCl
            | Op::LightVisible
            | Op::LightPdf
            | Op::Ambient
            | Op::Texture { .. }
            | Op::Attribute { .. }
            | Op::AttributeFound { .. }
            | Op::Trace { .. }
            | Op::Occlusion { .. }
            | Op::Probe { .. }
            | Op::Print { .. }
            | Op::If { .. }
            | Op::Illuminance { .. }
            | Op::Loop { .. }
            | Op::LoopVar(_)
            | Op::Proj(..) => false,
        }
    }

    /// Whether the op is a region (`If`, `Illuminance`, `Loop`).
    pub fn is_region(&self) -> bool {
        matches!(
            self,
            Op::If { .. } | Op::Illuminance { .. } | Op::Loop { .. }
        )
    }
}

impl Program {
    /// Runs `f` on each block of region `v` in turn, with the program (the blocks are taken
    /// out of the arena while `f` runs, so `f` may edit the program and add values, and put
    /// back after); returns the sum of what `f` returns. Nothing for a value that is not a
    /// region.
    pub fn rewrite_blocks(
        &mut self,
        v: Value,
        mut f: impl FnMut(&mut Program, &mut Block) -> usize,
    ) -> usize {
        let mut blocks: Vec<Block> = self.exprs[v.index()]
            .op
            .blocks_mut()
            .into_iter()
            .map(std::mem::take)
            .collect();
        let n = blocks.iter_mut().map(|b| f(self, b)).sum();
        for (slot, b) in self.exprs[v.index()]
            .op
            .blocks_mut()
            .into_iter()
            .zip(blocks)
        {
            *slot = b;
        }
        n
    }

    /// Appends an expr to the arena without listing it in any block; the caller lists it.
    pub fn add_expr(&mut self, expr: Expr) -> Value {
        self.exprs.push(expr);
        Value::new(self.exprs.len() - 1)
    }

    /// Replaces every use of `v` by `map[v]` (where `Some`) in operands, yields and
    /// outputs, following chains (`a → b → c` replaces `a` by `c`). The replaced values stay
    /// listed in their blocks: remove them or leave them to dead-code elimination.
    pub fn substitute(&mut self, map: &[Option<Value>]) {
        let resolve = |mut v: Value| {
            let mut hops = 0;
            while let Some(Some(next)) = map.get(v.index()) {
                if *next == v || hops > map.len() {
                    break;
                }
                v = *next;
                hops += 1;
            }
            v
        };
        for e in &mut self.exprs {
            for o in e.op.operands_mut() {
                *o = resolve(*o);
            }
            for b in e.op.blocks_mut() {
                for y in &mut b.yields {
                    *y = resolve(*y);
                }
            }
        }
        for y in &mut self.body.yields {
            *y = resolve(*y);
        }
        for o in &mut self.outputs {
            o.value = resolve(o.value);
        }
    }

    /// The values listed in the prelude and the body (nested blocks included), in
    /// evaluation order.
    pub fn listed(&self) -> Vec<Value> {
        let mut out = Vec::new();
        self.walk(&self.prelude, &mut |v| out.push(v));
        self.walk(&self.body, &mut |v| out.push(v));
        out
    }

    /// Drops values listed in no block, renumbers the arena in evaluation order (so handles
    /// are dense and operands precede users), and removes textures no op reads (the attribute table stays: its slots are stable).
    pub fn compact(&mut self) {
        let order = self.listed();
        let mut new_index: Vec<Option<Value>> = vec![None; self.exprs.len()];
        for (i, v) in order.iter().enumerate() {
            new_index[v.index()] = Some(Value::new(i));
        }
        let map = |v: Value| new_index.get(v.index()).copied().flatten().unwrap_or(v);
        let remap_block = |b: &mut Block| {
            for v in b.body.iter_mut().chain(b.yields.iter_mut()) {
                *v = map(*v);
            }
        };
        let mut exprs: Vec<Expr> = Vec::with_capacity(order.len());
        for v in &order {
            let mut e = self.exprs[v.index()].clone();
            for o in e.op.operands_mut() {
                *o = map(*o);
            }
            for b in e.op.blocks_mut() {
                remap_block(b);
            }
            exprs.push(e);
        }
        remap_block(&mut self.prelude);
        remap_block(&mut self.body);
        for o in &mut self.outputs {
            o.value = map(o.value);
        }
        self.exprs = exprs;

        // Textures: keep the referenced ones, in first-use order.
        let mut used: Vec<Option<u32>> = vec![None; self.textures.len()];
        let mut kept = Vec::new();
        for e in &mut self.exprs {
            if let Op::Texture { texture, .. } = &mut e.op {
                let slot = &mut used[*texture as usize];
                if slot.is_none() {
                    *slot = Some(kept.len() as u32);
                    kept.push(self.textures[*texture as usize].clone());
                }
                *texture = slot.expect("set above");
            }
        }
        self.textures = kept;
        // The attribute table is kept as it is (dead entries too): a slot names the same
        // attribute in every optimized form of a program, so a renderer that resolved the
        // slots of one form serves them all. `Needs::attributes` lists the live ones.
    }
}
