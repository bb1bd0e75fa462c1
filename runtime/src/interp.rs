//! The interpreter: runs any valid program, in f32 (shading) or f64 (the accuracy reference).
//!
//! It walks the program's blocks in order, evaluating each op with [`shadenet_graph::ops`];
//! an `If` runs only the arm its condition picks, `Illuminance` runs its body once per
//! light sample, and `Loop` runs its condition and body until the condition fails or the
//! iteration limit stops it (counted in [`ShadeOut::loop_limits`]). Every output then passes the guard: a non-finite component becomes 0 and is
//! counted in [`ShadeOut::nonfinite`].
//!
//! # The scene
//!
//! With a scene ([`ShadeCtx::scene`]) the interpreter asks it for what the scene ops need:
//!
//! - `Illuminance` runs its body for **every** light sample, blocked ones too; for each
//!   sample it asks [`SceneServices::occluded`] for the segment from the loop's point to the
//!   sample (once per sample and shading call: the answer is kept for the other light loops
//!   of the same call at the same point), and `light.visible` is 0 where it is blocked, 1
//!   elsewhere. A light loop whose body never reads `light.visible` asks nothing (its result
//!   cannot depend on the answer). Without a scene every sample is visible.
//! - `trace` calls [`SceneServices::trace`] from the fragment's `P` with the normalized
//!   direction at depth `ray_depth + 1` (wrapping); black without a scene or for a zero or
//!   non-finite direction.
//! - `occlusion` calls [`SceneServices::occlusion`] with the normalized normal, at least one
//!   sample and the fragment's seed, and clamps the answer to [0, 1] (a NaN answer counts as
//!   1); it is 1 without a scene, for a zero or non-finite normal, and for a maximum distance
//!   that is not positive (or NaN).
//! - `probe` calls [`SceneServices::probe`] through [`probe_field`] (the JIT's helper calls
//!   the same function): the field of the closest surface along the ray, 0 where there is
//!   none or no scene.
//! - `attribute` calls [`SceneServices::attribute`] through [`attribute_value`] (the JIT's
//!   helper calls the same function): the scene's value, or the op's default where the
//!   scene has none, gives a non-finite component, or there is no scene; `attribute.found`
//!   is true exactly where that lookup gives the scene's value ([`attribute_found`]).
//!
//! Arguments go to the scene in f32 (the f64 reference rounds them) and its answers are
//! widened back.
//!
//! A `printf`, `warning` or `error` op writes its message to the calling thread's log
//! ([`crate::messages`]) when it runs: an arm not taken writes nothing, a loop body once
//! per iteration.

use crate::ctx::{SceneServices, ShadeCtx, ShadeEnv};
use crate::lights;
use crate::messages;
use crate::texture::{TextureError, TextureSet};
use shadenet_graph::ir::{
    BinOp, Block, LOOP_ITERATION_LIMIT, Op, ProbeField, Program, Space, Stream, Value, XformKind,
};
use shadenet_graph::ops::printf::Arg;
use shadenet_graph::ops::{self, Real, Val};
use shadenet_graph::types::{ConstValue, Type};

/// Where each output's floats live in [`ShadeOut::values`].
#[derive(Clone, Debug, PartialEq)]
pub struct OutputSlot {
    /// The output's name.
    pub name: String,
    /// Its render component, if it is a component part.
    pub component: Option<u8>,
    /// Its type.
    pub ty: Type,
    /// First float in `values`.
    pub offset: usize,
}

/// The result of one shading call: every program output (each component part separately),
/// flattened to floats (bools and ints as 0/1 and their value).
#[derive(Clone, Debug, PartialEq)]
pub struct ShadeOut<F> {
    /// The output floats, laid out by the program's [`OutputSlot`]s.
    pub values: Vec<F>,
    /// Non-finite floats the guard replaced with 0 in this call.
    pub nonfinite: u32,
    /// Loop executions in this call that stopped at
    /// [`LOOP_ITERATION_LIMIT`](shadenet_graph::ir::LOOP_ITERATION_LIMIT) with their
    /// condition still true.
    pub loop_limits: u32,
}

impl<F> Default for ShadeOut<F> {
    fn default() -> Self {
        ShadeOut {
            values: Vec::new(),
            nonfinite: 0,
            loop_limits: 0,
        }
    }
}

/// A program prepared for interpretation in precision `F`.
#[derive(Clone, Debug)]
pub struct Interpreter<F: Real> {
    program: Program,
    /// Constants converted to `F` once, by arena index.
    consts: Vec<Option<Val<F>>>,
    /// Matrix table: constants and parameters of a matrix type, then the prelude's computed
    /// matrices (a matrix33 fills the first 9 elements, row-major).
    mats: Vec<[F; 16]>,
    /// For each `Construct` of a matrix (by arena index): its `Val::Mat` index; for each
    /// `Loop`, the first of its carried values' own matrix slots (one per carried value: a
    /// carried matrix is copied there after each body run, so that a construct running
    /// again in the next run cannot change a value the loop still carries). Those of the
    /// prelude index `mats`; those of the body index past it, into [`Scratch`]'s matrices.
    mat_index: Vec<u32>,
    /// Matrices the body constructs per fragment.
    body_mats: usize,
    slots: Vec<OutputSlot>,
    width: usize,
    /// For each region (by arena index): its `Proj` users as (arena index, result index).
    projs: Vec<Vec<(usize, u8)>>,
    /// The program's textures.
    textures: TextureSet,
    /// The prelude's values, evaluated once, by arena index.
    prelude: Vec<(usize, Val<F>)>,
    /// For each `Illuminance` (by arena index): whether its body reads `light.visible` (at
    /// any depth), so its samples need a shadow test.
    reads_visible: Vec<bool>,
}

/// Where every output of `program` lies in a fragment's output floats, and how many floats
/// that is: the layout every back end writes (bools and ints take one float each).
pub fn output_layout(program: &Program) -> (Vec<OutputSlot>, usize) {
    let mut slots = Vec::new();
    let mut width = 0;
    for o in &program.outputs {
        let ty = program.ty(o.value);
        slots.push(OutputSlot {
            name: o.name.clone(),
            component: o.component,
            ty,
            offset: width,
        });
        width += ty.width().max(1);
    }
    (slots, width)
}

/// Reusable per-thread storage for [`Interpreter::shade_with`].
#[derive(Clone, Debug)]
pub struct Scratch<F> {
    regs: Vec<Val<F>>,
    /// The current light sample and its visibility (1 or 0).
    light: Option<(lights::Sample<F>, F)>,
    /// Shadow-test answers of this shading call, by sample number (lights in order, their
    /// samples in order): 0 not asked yet, 1 visible, 2 blocked.
    visibility: Vec<u8>,
    /// The point the answers in `visibility` are for (bits of its f64 coordinates).
    visibility_at: Option<[u64; 3]>,
    /// Reusable buffers for light-loop sums (one per nesting level in use), so shading a
    /// fragment allocates nothing once the buffers exist.
    sums: Vec<Vec<Val<F>>>,
    /// Matrices computed in this shading call (see `Interpreter::mat_index`).
    mats: Vec<[F; 16]>,
    /// The carried values of the loops running now, innermost last (buffers come from and
    /// return to `sums`).
    loops: Vec<Vec<Val<F>>>,
    /// Loop executions stopped at the iteration limit in this shading call.
    loop_limits: u32,
    /// Body runs left to the loop nest running now.
    budget: u32,
}

impl<F> Default for Scratch<F> {
    fn default() -> Self {
        Scratch {
            regs: Vec::new(),
            light: None,
            visibility: Vec::new(),
            visibility_at: None,
            sums: Vec::new(),
            mats: Vec::new(),
            loops: Vec::new(),
            loop_limits: 0,
            budget: 0,
        }
    }
}

impl<F: Real> Interpreter<F> {
    /// Prepares a program: loads its textures and evaluates its prelude. The program must be
    /// valid (see `shadenet_graph::ir::validate`).
    pub fn new(program: &Program) -> Result<Interpreter<F>, TextureError> {
        let textures = TextureSet::load(&program.textures)?;
        Ok(Interpreter::with_textures(program, textures))
    }

    /// Prepares a program with already loaded textures (one per `Program::textures` entry).
    pub fn with_textures(program: &Program, textures: TextureSet) -> Interpreter<F> {
        let mut mats: Vec<[F; 16]> = Vec::new();
        let mut mat_of = |c: &ConstValue| -> Val<F> {
            if !c.ty().is_matrix() {
                return Val::from_const(c);
            }
            let mut m = [F::ZERO; 16];
            for (d, x) in m.iter_mut().zip(c.floats()) {
                *d = F::from_f64(*x);
            }
            mats.push(m);
            Val::Mat((mats.len() - 1) as u32)
        };
        let consts = program
            .exprs
            .iter()
            .map(|e| match &e.op {
                Op::Const(c) => Some(mat_of(c)),
                Op::Param(i) => program.params.get(*i as usize).map(|p| mat_of(&p.default)),
                _ => None,
            })
            .collect();
        let (mat_index, prelude_mats, body_mats) = matrix_indices(program, mats.len());
        let (slots, width) = output_layout(program);
        let mut projs = vec![Vec::new(); program.exprs.len()];
        for (i, e) in program.exprs.iter().enumerate() {
            if let Op::Proj(r, k) = &e.op
                && let Some(list) = projs.get_mut(r.index())
            {
                list.push((i, *k));
            }
        }
        let mut reads_visible = vec![false; program.exprs.len()];
        for (i, e) in program.exprs.iter().enumerate() {
            if let Op::Illuminance { body, .. } = &e.op {
                let mut reads = false;
                program.walk(body, &mut |v| reads |= *program.op(v) == Op::LightVisible);
                reads_visible[i] = reads;
            }
        }
        let mut interp = Interpreter {
            reads_visible,
            projs,
            program: program.clone(),
            consts,
            mats,
            mat_index,
            body_mats,
            slots,
            width,
            textures,
            prelude: Vec::new(),
        };
        // The prelude reads neither the fragment nor the environment (the validator ensures
        // it): evaluate it once against an empty context.
        let env = ShadeEnv::default();
        let ctx = ShadeCtx::new(Default::default(), &env);
        let mut scratch = Scratch::default();
        scratch.regs.resize(program.exprs.len(), Val::Int(0));
        scratch.mats.resize(prelude_mats, [F::ZERO; 16]);
        interp.block(&program.prelude, &ctx, &mut scratch);
        // The prelude's matrices join the table: their indices were numbered to follow it,
        // and the body's to follow them.
        interp.mats.append(&mut scratch.mats);
        interp.prelude = program
            .prelude
            .body
            .iter()
            .map(|v| (v.index(), scratch.regs[v.index()]))
            .collect();
        interp
    }

    /// The program being run.
    pub fn program(&self) -> &Program {
        &self.program
    }

    /// The prelude's values (evaluated once, when the interpreter was made), as (arena index,
    /// value) in prelude order. A matrix value is an index into [`Interpreter::matrices`].
    pub fn prelude_values(&self) -> &[(usize, Val<F>)] {
        &self.prelude
    }

    /// The matrix table, row-major: constants and parameters of a matrix type, then the
    /// matrices the prelude constructs (a matrix33 in the first 9 elements).
    pub fn matrices(&self) -> &[[F; 16]] {
        &self.mats
    }

    /// The output layout.
    pub fn slots(&self) -> &[OutputSlot] {
        &self.slots
    }

    /// Shades one fragment (allocates scratch; see [`Interpreter::shade_with`] to reuse it).
    pub fn shade(&self, ctx: &ShadeCtx) -> ShadeOut<F> {
        let mut scratch = Scratch::default();
        let mut out = ShadeOut {
            values: Vec::new(),
            nonfinite: 0,
            loop_limits: 0,
        };
        self.shade_with(ctx, &mut scratch, &mut out);
        out
    }

    /// Shades one fragment into `out`, reusing `scratch`.
    pub fn shade_with(&self, ctx: &ShadeCtx, scratch: &mut Scratch<F>, out: &mut ShadeOut<F>) {
        scratch.regs.clear();
        scratch.regs.resize(self.program.exprs.len(), Val::Int(0));
        scratch.light = None;
        scratch.visibility_at = None;
        scratch.loops.clear();
        scratch.loop_limits = 0;
        scratch.mats.resize(self.body_mats, [F::ZERO; 16]);
        for &(i, v) in &self.prelude {
            scratch.regs[i] = v;
        }
        self.block(&self.program.body, ctx, scratch);
        out.values.clear();
        out.values.resize(self.width, F::ZERO);
        out.nonfinite = 0;
        out.loop_limits = scratch.loop_limits;
        for (o, slot) in self.program.outputs.iter().zip(&self.slots) {
            let v = scratch.regs[o.value.index()];
            let dst = &mut out.values[slot.offset..];
            match v {
                Val::Bool(b) => dst[0] = if b { F::ONE } else { F::ZERO },
                Val::Int(i) => dst[0] = F::from_i32(i),
                Val::Mat(_) => {
                    let m = self.mat(v, scratch);
                    for (d, x) in dst.iter_mut().zip(&m[..slot.ty.width()]) {
                        if x.is_finite() {
                            *d = *x;
                        } else {
                            out.nonfinite += 1;
                        }
                    }
                }
                v => {
                    for (d, x) in dst.iter_mut().zip(v.floats()) {
                        if x.is_finite() {
                            *d = *x;
                        } else {
                            out.nonfinite += 1;
                        }
                    }
                }
            }
        }
    }

    fn block(&self, block: &Block, ctx: &ShadeCtx, s: &mut Scratch<F>) {
        for &v in &block.body {
            let r = self.eval(v, ctx, s);
            s.regs[v.index()] = r;
        }
    }

    fn eval(&self, v: Value, ctx: &ShadeCtx, s: &mut Scratch<F>) -> Val<F> {
        let expr = &self.program.exprs[v.index()];
        let reg = |x: &Value| s.regs[x.index()];
        match &expr.op {
            Op::Const(_) | Op::Param(_) => self.consts[v.index()].unwrap_or(Val::Int(0)),
            Op::Stream(st) => stream(*st, ctx),
            Op::Transform {
                kind,
                from,
                to,
                arg,
            } => Val::Vec3(transform(ctx.env, *kind, *from, *to, reg(arg).as_vec3())),
            Op::ComponentEnabled(k) => Val::Bool(ctx.mask & (1u32 << (*k as u32 & 31)) != 0),
            Op::Unary(op, a) => ops::unary(*op, reg(a)),
            Op::Binary(BinOp::MulPoint, m, p) => {
                Val::Vec3(ops::mul_point(&self.mat(reg(m), s), reg(p).as_vec3()))
            }
            Op::Binary(BinOp::MulVector, m, p) => {
                Val::Vec3(ops::mul_vector(&self.mat(reg(m), s), reg(p).as_vec3()))
            }
            Op::Binary(op, a, b) => ops::binary(*op, reg(a), reg(b)),
            Op::Select { cond, a, b } => ops::select(reg(cond), reg(a), reg(b)),
            Op::Construct(args) if expr.ty.is_some_and(Type::is_matrix) => {
                let mut m = [F::ZERO; 16];
                for (d, a) in m.iter_mut().zip(args) {
                    *d = reg(a).as_float();
                }
                let i = self.mat_index[v.index()];
                if let Some(d) = (i as usize)
                    .checked_sub(self.mats.len())
                    .and_then(|k| s.mats.get_mut(k))
                {
                    *d = m;
                }
                Val::Mat(i)
            }
            Op::Construct(args) => {
                let vals: [Val<F>; 4] =
                    std::array::from_fn(|i| args.get(i).map_or(Val::Int(0), reg));
                ops::construct(expr.ty.unwrap_or(Type::Vec3), &vals[..args.len().min(4)])
            }
            Op::Extract(a, i) => match reg(a) {
                m @ Val::Mat(_) => {
                    Val::Float(self.mat(m, s).get(*i as usize).copied().unwrap_or(F::ZERO))
                }
                x => ops::extract(x, *i),
            },
            Op::Splat(a) => ops::splat(expr.ty.unwrap_or(Type::Vec3), reg(a)),
            Op::Convert(a) => ops::convert(expr.ty.unwrap_or(Type::Float), reg(a)),
            Op::Call(i, args) => {
                // Intrinsics take at most four operands (the validator checks their types).
                let mut vals = [Val::Int(0); 4];
                for (d, a) in vals.iter_mut().zip(args) {
                    *d = reg(a);
                }
                ops::intrinsic(*i, &vals[..args.len().min(4)])
            }
            Op::If { cond, then_, else_ } => {
                let arm = if reg(cond).as_bool() { then_ } else { else_ };
                self.block(arm, ctx, s);
                self.store_results(v, &arm.yields, s);
                Val::Int(0)
            }
            Op::Illuminance { p, body } => {
                let p = reg(p).as_vec3();
                let n = body.yields.len();
                let mut sums = s.sums.pop().unwrap_or_default();
                sums.clear();
                sums.extend(body.yields.iter().map(|y| Val::zero(self.program.ty(*y))));
                let outer = s.light;
                let shadows = ctx.scene.filter(|_| self.reads_visible[v.index()]);
                if shadows.is_some() {
                    let at = p.map(|x| x.to_f64().to_bits());
                    if s.visibility_at != Some(at) {
                        s.visibility_at = Some(at);
                        s.visibility.clear();
                    }
                }
                let mut number = 0;
                for (li, light) in ctx.env.lights.iter().enumerate() {
                    for k in 0..lights::sample_count(light) {
                        let Some(sample) = lights::sample(light, li as u32, k, p, ctx.frag.seed)
                        else {
                            continue;
                        };
                        let visible = match shadows {
                            Some(scene) => visible(scene, p, &sample, number, s),
                            None => true,
                        };
                        number += 1;
                        let visible = if visible { F::ONE } else { F::ZERO };
                        s.light = Some((sample, visible));
                        self.block(body, ctx, s);
                        for (sum, y) in sums.iter_mut().zip(&body.yields) {
                            *sum = ops::binary(BinOp::Add, *sum, s.regs[y.index()]);
                        }
                    }
                }
                s.light = outer;
                debug_assert_eq!(sums.len(), n);
                self.store_sums(v, &sums, s);
                s.sums.push(sums);
                Val::Int(0)
            }
            Op::Loop { init, cond, body } => {
                let mut cur = s.sums.pop().unwrap_or_default();
                cur.clear();
                cur.extend(init.iter().map(reg));
                s.loops.push(cur);
                self.run_loop(cond, body, self.mat_index[v.index()], ctx, s);
                let cur = s.loops.pop().unwrap_or_default();
                self.store_sums(v, &cur, s);
                s.sums.push(cur);
                Val::Int(0)
            }
            Op::LoopVar(k) => s
                .loops
                .last()
                .and_then(|c| c.get(*k as usize))
                .copied()
                .unwrap_or(Val::Int(0)),
            Op::LightL => Val::Vec3(s.light.map_or([F::ZERO; 3], |l| l.0.l)),
            Op::LightCl => Val::Vec3(s.light.map_or([F::ZERO; 3], |l| l.0.cl)),
            Op::LightVisible => Val::Float(s.light.map_or(F::ONE, |l| l.1)),
            Op::LightPdf => Val::Float(s.light.map_or(F::ZERO, |l| l.0.pdf)),
            Op::Ambient => Val::Vec3(lights::ambient(&ctx.env.lights)),
            Op::Proj(..) => s.regs[v.index()],
            Op::Texture {
                texture,
                uv,
                derivs,
                sampling,
                alpha,
            } => {
                let v2 = |v: &Value| {
                    let r = reg(v);
                    let f = r.floats();
                    [f[0], f[1]]
                };
                let duv = derivs.map_or([[F::ZERO; 2]; 2], |[dx, dy]| [v2(&dx), v2(&dy)]);
                let t = self
                    .textures
                    .get(*texture)
                    .map_or([F::ZERO; 4], |t| t.lookup(v2(uv), duv, *sampling));
                if *alpha {
                    Val::Float(t[3])
                } else {
                    Val::Vec3([t[0], t[1], t[2]])
                }
            }
            Op::Trace { dir, ray_type, pdf } => {
                let pdf = pdf.map_or(F::ZERO, |p| reg(&p).as_float());
                Val::Vec3(trace(ctx, reg(dir).as_vec3(), *ray_type, pdf))
            }
            Op::Attribute { slot, default } => {
                let d = reg(default);
                let mut v = d;
                attribute_value(ctx.scene, *slot, d.floats(), floats_mut(&mut v));
                v
            }
            Op::AttributeFound { slot } => {
                let width = self.program.attributes[*slot as usize].ty.width();
                Val::Bool(attribute_found(ctx.scene, *slot, width))
            }
            Op::Probe {
                field,
                origin,
                dir,
                min_distance,
                max_distance,
            } => {
                let r = probe_field(
                    ctx.scene,
                    *field,
                    reg(origin).as_vec3(),
                    reg(dir).as_vec3(),
                    reg(min_distance).as_float(),
                    reg(max_distance).as_float(),
                );
                match field.ty() {
                    Type::Vec3 => Val::Vec3(r),
                    _ => Val::Float(r[0]),
                }
            }
            Op::Print {
                severity,
                format,
                args,
            } => {
                let args: Vec<_> = args.iter().map(|a| self.print_arg(*a, s)).collect();
                messages::write(*severity, format, &args);
                Val::Int(0)
            }
            Op::Occlusion {
                n,
                samples,
                max_distance,
            } => Val::Float(occlusion(
                ctx,
                reg(n).as_vec3(),
                reg(samples).as_int(),
                reg(max_distance).as_float(),
            )),
        }
    }

    /// Runs a loop whose carried values are `s.loops`' last entry: the condition, then the
    /// body while it holds and the loop nest has iterations left (an outermost loop starts
    /// the nest's budget of [`LOOP_ITERATION_LIMIT`] body runs; the loops nested in it share
    /// it).
    fn run_loop(&self, cond: &Block, body: &Block, carry: u32, ctx: &ShadeCtx, s: &mut Scratch<F>) {
        if s.loops.len() == 1 {
            s.budget = LOOP_ITERATION_LIMIT;
        }
        loop {
            self.block(cond, ctx, s);
            if !cond
                .yields
                .first()
                .is_some_and(|c| s.regs[c.index()].as_bool())
            {
                return;
            }
            if s.budget == 0 {
                s.loop_limits += 1;
                return;
            }
            s.budget -= 1;
            self.block(body, ctx, s);
            let regs = &s.regs;
            if !body
                .yields
                .iter()
                .any(|y| matches!(regs[y.index()], Val::Mat(_)))
            {
                if let Some(cur) = s.loops.last_mut() {
                    for (c, y) in cur.iter_mut().zip(&body.yields) {
                        *c = regs[y.index()];
                    }
                }
                continue;
            }
            // The next values; carried matrices read (all of them first: one may be another's
            // slot) and then copied into the loop's own slots.
            let next: Vec<Val<F>> = body.yields.iter().map(|y| s.regs[y.index()]).collect();
            let copies: Vec<(usize, [F; 16])> = next
                .iter()
                .enumerate()
                .filter(|(_, v)| matches!(v, Val::Mat(_)))
                .map(|(k, v)| (k, self.mat(*v, s)))
                .collect();
            for (k, m) in copies {
                let slot = carry as usize + k;
                if let Some(d) = slot
                    .checked_sub(self.mats.len())
                    .and_then(|j| s.mats.get_mut(j))
                {
                    *d = m;
                }
            }
            if let Some(cur) = s.loops.last_mut() {
                for (k, (c, v)) in cur.iter_mut().zip(next).enumerate() {
                    *c = match v {
                        Val::Mat(_) => Val::Mat(carry + k as u32),
                        v => v,
                    };
                }
            }
        }
    }

    fn store_results(&self, region: Value, yields: &[Value], s: &mut Scratch<F>) {
        for &(i, k) in &self.projs[region.index()] {
            if let Some(y) = yields.get(k as usize) {
                s.regs[i] = s.regs[y.index()];
            }
        }
    }

    fn store_sums(&self, region: Value, vals: &[Val<F>], s: &mut Scratch<F>) {
        for &(i, k) in &self.projs[region.index()] {
            if let Some(v) = vals.get(k as usize) {
                s.regs[i] = *v;
            }
        }
    }

    /// Value `v` as a message formats it.
    fn print_arg(&self, v: Value, s: &Scratch<F>) -> Arg {
        match s.regs[v.index()] {
            Val::Bool(b) => Arg::Int(i64::from(b)),
            Val::Int(i) => Arg::Int(i64::from(i)),
            Val::Float(x) => messages::float_arg(x.to_f64()),
            x @ Val::Mat(_) => {
                let n = self.program.ty(v).width();
                messages::floats_arg(self.mat(x, s)[..n].iter().map(|x| x.to_f64()))
            }
            x => messages::floats_arg(x.floats().iter().map(|x| x.to_f64())),
        }
    }

    /// A matrix value: from the table, or computed in this shading call (zero if `v` is no
    /// matrix, which a valid program never gives).
    fn mat(&self, v: Val<F>, s: &Scratch<F>) -> [F; 16] {
        let Val::Mat(i) = v else {
            return [F::ZERO; 16];
        };
        let i = i as usize;
        match i.checked_sub(self.mats.len()) {
            None => self.mats[i],
            Some(k) => s.mats.get(k).copied().unwrap_or([F::ZERO; 16]),
        }
    }
}

/// Numbers the matrices a program constructs (by arena index), and gives each loop one
/// slot per carried value: those in the prelude from `base`, then those in the body.
/// Returns the numbers and how many slots each part has.
fn matrix_indices(program: &Program, base: usize) -> (Vec<u32>, usize, usize) {
    let mut in_prelude = vec![false; program.exprs.len()];
    program.walk(&program.prelude, &mut |v| in_prelude[v.index()] = true);
    let in_prelude = &in_prelude;
    let slots = |e: &shadenet_graph::ir::Expr| match &e.op {
        Op::Construct(_) if e.ty.is_some_and(Type::is_matrix) => 1,
        Op::Loop { init, .. } => init.len(),
        _ => 0,
    };
    let mut index = vec![0; program.exprs.len()];
    let mut n = base;
    let mut prelude = 0;
    for part in [true, false] {
        for (i, e) in program.exprs.iter().enumerate() {
            if in_prelude[i] == part && slots(e) > 0 {
                index[i] = n as u32;
                n += slots(e);
            }
        }
        if part {
            prelude = n - base;
        }
    }
    (index, prelude, n - base - prelude)
}

/// Whether light sample number `number` (seen from `p`) reaches `p`: the scene's answer, asked
/// once per sample and shading call at the same point.
fn visible<F: Real>(
    scene: &dyn SceneServices,
    p: [F; 3],
    sample: &lights::Sample<F>,
    number: usize,
    s: &mut Scratch<F>,
) -> bool {
    if s.visibility.len() <= number {
        s.visibility.resize(number + 1, 0);
    }
    match s.visibility[number] {
        1 => true,
        2 => false,
        _ => {
            let open = sample_visible(Some(scene), p, sample.to);
            s.visibility[number] = if open { 1 } else { 2 };
            open
        }
    }
}

/// Whether the segment from `p` to a light sample's `to` is open: the scene's
/// [`SceneServices::occluded`] answer, negated, with the points rounded to f32; always true
/// without a scene. Shared by every CPU back end.
pub fn sample_visible<F: Real>(scene: Option<&dyn SceneServices>, p: [F; 3], to: [F; 3]) -> bool {
    let Some(scene) = scene else {
        return true;
    };
    let from = p.map(|x| x.to_f64() as f32);
    let to = to.map(|x| x.to_f64() as f32);
    !scene.occluded(from, to)
}

/// The `trace` op: radiance along `normalize(dir)` from the fragment's `P` (black without a
/// scene, or for a zero or non-finite direction).
/// `pdf` is the BSDF sample's density (0 for none; a negative or NaN one counts as 0).
pub fn trace<F: Real>(ctx: &ShadeCtx, dir: [F; 3], ray_type: i32, pdf: F) -> [F; 3] {
    trace_radiance(
        ctx.scene,
        ctx.frag.p,
        dir,
        ray_type,
        ctx.frag.ray_depth,
        pdf,
    )
}

/// [`trace`] from its parts: the scene, the fragment's `p` and `ray_depth` (the ray goes out
/// at `ray_depth + 1`, wrapping). Shared by every CPU back end.
pub fn trace_radiance<F: Real>(
    scene: Option<&dyn SceneServices>,
    p: [f32; 3],
    dir: [F; 3],
    ray_type: i32,
    ray_depth: i32,
    pdf: F,
) -> [F; 3] {
    let Some(scene) = scene else {
        return [F::ZERO; 3];
    };
    let d = ops::normalize(dir).map(|x| x.to_f64() as f32);
    if d.iter().any(|x| !x.is_finite()) || d.iter().all(|x| *x == 0.0) {
        return [F::ZERO; 3];
    }
    let depth = ray_depth.wrapping_add(1);
    let pdf = pdf.to_f64() as f32;
    let pdf = if pdf > 0.0 { pdf } else { 0.0 };
    let c = scene.trace(p, d, ray_type, depth, pdf);
    c.map(|x| F::from_f64(x as f64))
}

/// The `occlusion` op: the scene's ambient occlusion at the fragment's `P` around `n`, in
/// [0, 1] (1 where nothing can be asked: see the module documentation).
pub fn occlusion<F: Real>(ctx: &ShadeCtx, n: [F; 3], samples: i32, max_distance: F) -> F {
    occlusion_value(
        ctx.scene,
        ctx.frag.p,
        n,
        samples,
        max_distance,
        ctx.frag.seed,
    )
}

/// The value of geometry attribute `slot` at the fragment whose services are `scene`, into
/// `out` (as many floats as `default`, 1 to 4): the scene's
/// ([`SceneServices::attribute`]), or `default` where the scene has none, there is no
/// scene, or a component it gives is not finite. The one lookup of [`Op::Attribute`]:
/// every CPU back end calls it, so they agree bit for bit.
pub fn attribute_value<F: Real>(
    scene: Option<&dyn SceneServices>,
    slot: u32,
    default: &[F],
    out: &mut [F],
) {
    let n = default.len().min(4);
    match attribute_lookup(scene, slot, n) {
        Some(got) => {
            for (o, x) in out.iter_mut().zip(&got[..n]) {
                *o = F::from_f64(f64::from(*x));
            }
        }
        None => out[..n].copy_from_slice(&default[..n]),
    }
}

/// Whether geometry attribute `slot`, read as `width` floats (1 to 4), is found at the
/// fragment whose services are `scene`: exactly where [`attribute_value`] gives the
/// scene's value rather than the default. The one lookup of [`Op::AttributeFound`].
pub fn attribute_found(scene: Option<&dyn SceneServices>, slot: u32, width: usize) -> bool {
    attribute_lookup(scene, slot, width.min(4)).is_some()
}

/// The scene's `n` floats of attribute `slot` (the rest 0), or `None` where there is no
/// scene, the scene has no such attribute, or a component it gives is not finite.
fn attribute_lookup(scene: Option<&dyn SceneServices>, slot: u32, n: usize) -> Option<[f32; 4]> {
    let mut got = [0.0f32; 4];
    let found = scene.is_some_and(|s| s.attribute(slot, &mut got[..n]));
    (found && got[..n].iter().all(|x| x.is_finite())).then_some(got)
}

/// The float components of a value, mutably (empty for bool, int and matrices).
fn floats_mut<F>(v: &mut Val<F>) -> &mut [F] {
    match v {
        Val::Float(x) => std::slice::from_mut(x),
        Val::Vec2(x) => x,
        Val::Vec3(x) => x,
        Val::Vec4(x) => x,
        _ => &mut [],
    }
}

/// [`occlusion`] from its parts: the scene, the fragment's `p` and `seed`. Shared by every
/// CPU back end.
pub fn occlusion_value<F: Real>(
    scene: Option<&dyn SceneServices>,
    p: [f32; 3],
    n: [F; 3],
    samples: i32,
    max_distance: F,
    seed: u32,
) -> F {
    let Some(scene) = scene else {
        return F::ONE;
    };
    let n = ops::normalize(n).map(|x| x.to_f64() as f32);
    let max_distance = max_distance.to_f64() as f32;
    let reaches = max_distance > 0.0; // false for NaN
    if n.iter().any(|x| !x.is_finite()) || n.iter().all(|x| *x == 0.0) || !reaches {
        return F::ONE;
    }
    let samples = samples.max(1) as u32;
    let o = scene.occlusion(p, n, samples, max_distance, seed);
    if o.is_nan() {
        F::ONE
    } else {
        F::from_f64(o.clamp(0.0, 1.0) as f64)
    }
}

/// Field `field` of the closest surface along the probe ray from `origin` towards `dir`
/// between `min_distance` and `max_distance` ([`SceneServices::probe`]), in the first one
/// (float fields) or three components: zeros where the ray hits nothing, there is no scene,
/// the direction is zero or not finite, the origin is not finite, or the distances leave
/// no interval (a NaN or negative minimum counts as 0; a NaN maximum, or one below the
/// minimum, finds nothing). The one lookup of [`Op::Probe`]: every CPU back end calls it
/// (arguments to the scene in f32), so they agree bit for bit.
pub fn probe_field<F: Real>(
    scene: Option<&dyn SceneServices>,
    field: ProbeField,
    origin: [F; 3],
    dir: [F; 3],
    min_distance: F,
    max_distance: F,
) -> [F; 3] {
    let zero = [F::ZERO; 3];
    let Some(scene) = scene else {
        return zero;
    };
    let d = ops::normalize(dir).map(|x| x.to_f64() as f32);
    let o = origin.map(|x| x.to_f64() as f32);
    let lo = (min_distance.to_f64() as f32).max(0.0);
    let hi = max_distance.to_f64() as f32;
    let bad = |v: &[f32; 3]| v.iter().any(|x| !x.is_finite());
    let interval = hi.partial_cmp(&lo).is_some_and(|c| c.is_ge());
    if bad(&d) || d.iter().all(|x| *x == 0.0) || bad(&o) || !interval {
        return zero;
    }
    let Some(hit) = scene.probe(o, d, lo, hi) else {
        return zero;
    };
    let w = |v: [f32; 3]| v.map(|x| F::from_f64(f64::from(x)));
    let one = |x: f32| [F::from_f64(f64::from(x)), F::ZERO, F::ZERO];
    match field {
        ProbeField::Hit => one(1.0),
        ProbeField::HitDist => one(hit.distance),
        ProbeField::P => w(hit.p),
        ProbeField::N => w(hit.n),
        ProbeField::Ng => w(hit.ng),
        ProbeField::U => one(hit.uv[0]),
        ProbeField::V => one(hit.uv[1]),
    }
}

fn stream<F: Real>(st: Stream, ctx: &ShadeCtx) -> Val<F> {
    let f = &ctx.frag;
    let v3 = |v: [f32; 3]| Val::Vec3(v.map(|x| F::from_f64(x as f64)));
    match st {
        Stream::P => v3(f.p),
        Stream::N => v3(f.n),
        Stream::Ng => v3(f.ng),
        Stream::I => v3(f.i),
        Stream::Uv => Val::Vec2(f.uv.map(|x| F::from_f64(x as f64))),
        Stream::DPdu => v3(f.dpdu),
        Stream::DPdv => v3(f.dpdv),
        Stream::DPdx => v3(f.dpdx),
        Stream::DPdy => v3(f.dpdy),
        Stream::Time => Val::Float(F::from_f64(f.time as f64)),
        Stream::RayType => Val::Int(f.ray_type),
        Stream::RayDepth => Val::Int(f.ray_depth),
        Stream::Rand => Val::Vec4(f.rand.map(|x| F::from_f64(x as f64))),
    }
}

/// Moves a vec3 from space `from` to space `to` through world space.
pub fn transform<F: Real>(
    env: &ShadeEnv,
    kind: XformKind,
    from: Space,
    to: Space,
    v: [F; 3],
) -> [F; 3] {
    if from == to {
        return v;
    }
    let conv = |m: &[f64; 16]| m.map(F::from_f64);
    let mut v = v;
    if let Some(t) = env.transform(from) {
        // space → world: the inverse matrix (and for normals, the transpose of the forward one)
        v = ops::transform(kind, &conv(&t.inv), &conv(&t.m), v);
    }
    if let Some(t) = env.transform(to) {
        v = ops::transform(kind, &conv(&t.m), &conv(&t.inv), v);
    }
    v
}
