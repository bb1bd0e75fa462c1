//! Lowering: one IR block tree to one CLIF function, in one of three modes.
//!
//! - **Scalar**: one fragment; floats are `f32`, ints `i32`, bools `i8` (0/1).
//! - **Batch**: four fragments in lockstep; floats are `f32x4`, ints `i32x4`, bools `i32x4`
//!   lane masks (all ones / zero). Every value is varying in this mode (uniform values are
//!   splatted).
//! - **Prelude**: the program's prelude, scalar, its values stored into the uniform block.
//!
//! A value of the IR becomes one CLIF value per component (a vec3 is three, a matrix44
//! sixteen). Constants, streams, parameters and prelude values are emitted where they are
//! *used*, not where they are listed, so that a use inside a conditional arm never refers to
//! a value of another arm: constants are rematerialized at each use; reads of memory that
//! does not change during a call (fragment streams, uniform slots, the environment's
//! matrices and ambient light) are loaded once per block scope and reused by the scope and
//! the scopes nested in it. That is load forwarding of immutable inputs, not value
//! numbering: every arithmetic op of the program is emitted as written (with CSE off, the
//! multiplication tree keeps all its products).
//!
//! Conditionals (`If`): the scalar mode branches. The batch mode computes the lanes that take
//! each arm under the current active mask, runs the then arm only if some lane takes it and
//! the else arm only if some lane takes that one, and blends the results per lane with the
//! condition mask (`bitselect`). When all lanes agree, one arm is skipped; when they diverge
//! both run, each with its own active mask for nested conditionals.
//!
//! Loops (`Loop`, `lower/loops.rs`): one CLIF loop per IR loop, never unrolled: the carried
//! values are `Variable`s read at the header (what `loop.var` reads) and redefined at the
//! end of the body, with an i32 count of the body's runs checked against the iteration
//! limit where the condition holds (a stop there is added to `CallCtx::loop_limits`). The
//! batch mode runs the lanes in lockstep under a running mask (the active mask, narrowed by
//! the condition at every header): it leaves when no lane runs, the body runs with the
//! running mask as its active mask, and its yields replace the carried values only in the
//! running lanes (`bitselect`), so a lane that has left keeps its values.
//!
//! Numerics follow `shadenet_graph::ops` exactly: `+ - * /`, `sqrt`, comparisons, selects,
//! `min`/`max` (as `a < b ? a : b`), `floor`/`ceil`/`fract`, `abs`, `neg`, dot products
//! summed left to right from `0.0`, the total division and square root — each one IEEE
//! instruction in the same order as the Rust code, no fused multiply-add. Transcendentals,
//! noise, colour conversions, textures and light samples call the Rust functions the
//! interpreter calls ([`crate::abi`]).

mod loops;

use crate::abi::{self, ctx_offset};
use cranelift_codegen::ir::condcodes::{FloatCC, IntCC};
use cranelift_codegen::ir::immediates::Ieee32;
use cranelift_codegen::ir::types::{F32, F32X4, I8, I32, I32X4};
use cranelift_codegen::ir::{
    AbiParam, BlockArg, ConstantData, Endianness, FuncRef, InstBuilder, MemFlagsData, Signature,
    StackSlot, StackSlotData, StackSlotKind, Type as ClifType, Value as V,
};
use cranelift_frontend::{FunctionBuilder, Variable};
use cranelift_jit::JITModule;
use cranelift_module::{FuncId, Linkage, Module};
use shadenet_graph::ir::{
    BinOp, Block, Intrinsic, Op, ProbeField, Program, Space, Stream, UnOp, Value, XformKind,
};
use shadenet_graph::types::{ConstValue, Type};
use shadenet_runtime::{Fragment, FragmentX4};
use std::collections::HashMap;
use std::mem::offset_of;

/// Which function is being built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// One fragment.
    Scalar,
    /// Four fragments, f32x4.
    Batch,
    /// The prelude, once per material.
    Prelude,
}

/// Why lowering stopped: an op this back end does not compile.
#[derive(Clone, Debug)]
pub struct Unsupported {
    /// The value.
    pub value: Value,
    /// The op, briefly.
    pub op: String,
    /// Why it is not compiled.
    pub reason: String,
}

/// Where parameters and prelude values live in the uniform block (32-bit slots).
#[derive(Clone, Debug, Default)]
pub struct UniformLayout {
    /// First slot of each parameter.
    pub params: Vec<usize>,
    /// First slot of each prelude value, by arena index.
    pub prelude: HashMap<usize, usize>,
    /// Total slots.
    pub size: usize,
}

impl UniformLayout {
    /// Lays out the parameters, then the prelude values.
    pub fn new(p: &Program) -> UniformLayout {
        let mut l = UniformLayout::default();
        for d in &p.params {
            l.params.push(l.size);
            l.size += comps(d.ty);
        }
        for &v in &p.prelude.body {
            if let Some(ty) = p.expr(v).ty {
                l.prelude.insert(v.index(), l.size);
                l.size += comps(ty);
            }
        }
        l
    }
}

/// Components (CLIF values) of an IR type.
pub fn comps(ty: Type) -> usize {
    match ty {
        Type::Matrix44 => 16,
        t => t.width().max(1),
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Kind {
    F,
    I,
    B,
}

fn kind(ty: Type) -> Kind {
    match ty {
        Type::Bool => Kind::B,
        Type::Int | Type::String => Kind::I,
        _ => Kind::F,
    }
}

/// The helper functions declared in the module, shared by all of its functions.
pub struct Helpers {
    /// Scalar and four-lane function of each math helper.
    math: HashMap<&'static str, (FuncId, FuncId)>,
    mem: HashMap<&'static str, (FuncId, FuncId)>,
    /// The message helpers, scalar and batch (`abi::sn_print`, `abi::sn_print_x4`).
    print: (FuncId, FuncId),
}

impl Helpers {
    /// Declares every helper as an imported symbol of `module`.
    pub fn declare(module: &mut JITModule) -> Result<Helpers, String> {
        let ptr = module.target_config().pointer_type();
        let mut math = HashMap::new();
        let mut x4_sig = module.make_signature();
        x4_sig.params.extend([AbiParam::new(ptr); 2]);
        for name in abi::MATH_NAMES {
            let h = abi::math_helper(name).ok_or("unknown math helper")?;
            let mut sig = module.make_signature();
            for _ in 0..h.arity {
                sig.params.push(AbiParam::new(F32));
            }
            sig.returns.push(AbiParam::new(F32));
            let id = module
                .declare_function(name, Linkage::Import, &sig)
                .map_err(|e| e.to_string())?;
            let x4 = module
                .declare_function(&format!("{name}_x4"), Linkage::Import, &x4_sig)
                .map_err(|e| e.to_string())?;
            math.insert(*name, (id, x4));
        }
        let mut mem = HashMap::new();
        for h in abi::MEM_HELPERS {
            let mut sig = module.make_signature();
            sig.params.extend([
                AbiParam::new(ptr),
                AbiParam::new(I32),
                AbiParam::new(ptr),
                AbiParam::new(ptr),
            ]);
            let s = module
                .declare_function(h.name, Linkage::Import, &sig)
                .map_err(|e| e.to_string())?;
            let b = module
                .declare_function(&format!("{}_x4", h.name), Linkage::Import, &sig)
                .map_err(|e| e.to_string())?;
            mem.insert(h.name, (s, b));
        }
        let mut sig = module.make_signature();
        sig.params
            .extend([AbiParam::new(ptr), AbiParam::new(I32), AbiParam::new(ptr)]);
        let mut print = [None; 2];
        for (slot, name) in print.iter_mut().zip(["sn_print", "sn_print_x4"]) {
            *slot = Some(
                module
                    .declare_function(name, Linkage::Import, &sig)
                    .map_err(|e| e.to_string())?,
            );
        }
        let [Some(s), Some(b)] = print else {
            return Err("message helpers not declared".into());
        };
        Ok(Helpers {
            math,
            mem,
            print: (s, b),
        })
    }

    /// Every helper symbol and its address, for the JIT builder.
    pub fn symbols() -> Vec<(String, *const u8)> {
        let mut v = Vec::new();
        for name in abi::MATH_NAMES {
            if let Some(h) = abi::math_helper(name) {
                v.push((name.to_string(), h.ptr));
                v.push((format!("{name}_x4"), h.x4));
            }
        }
        for h in abi::MEM_HELPERS {
            v.push((h.name.to_string(), h.scalar as *const u8));
            v.push((format!("{}_x4", h.name), h.batch as *const u8));
        }
        v.push(("sn_print".into(), abi::sn_print as *const u8));
        v.push(("sn_print_x4".into(), abi::sn_print_x4 as *const u8));
        v
    }
}

/// The signature of an entry point in `mode`.
pub fn signature(module: &JITModule, mode: Mode) -> Signature {
    let ptr = module.target_config().pointer_type();
    let mut sig = module.make_signature();
    match mode {
        Mode::Scalar => {
            sig.params.extend([AbiParam::new(ptr); 3]);
            sig.returns.push(AbiParam::new(I32));
        }
        Mode::Batch => {
            sig.params.extend([AbiParam::new(ptr); 3]);
            sig.params.push(AbiParam::new(I32));
            sig.returns.push(AbiParam::new(I32));
        }
        Mode::Prelude => sig.params.extend([AbiParam::new(ptr); 2]),
    }
    sig
}

/// The helper-call slot: up to 12 argument floats, then up to 12 result floats (16 bytes
/// each in batch mode).
const SCRATCH_ARGS: u32 = 12 * 16;
const SCRATCH_BYTES: u32 = 2 * SCRATCH_ARGS;

/// Builds one function.
pub struct Lowerer<'a, 'b> {
    p: &'a Program,
    mode: Mode,
    b: FunctionBuilder<'b>,
    module: &'a mut JITModule,
    helpers: &'a Helpers,
    layout: &'a UniformLayout,
    ptr: ClifType,
    /// Lowered values by arena index (empty: not lowered, or rematerialized).
    vals: Vec<Vec<V>>,
    /// Region results by arena index of the region.
    regions: HashMap<usize, Vec<Vec<V>>>,
    funcs: HashMap<FuncId, FuncRef>,
    ctx: V,
    frag: V,
    /// Where this fragment's (batch: this packet's) outputs go.
    out: V,
    uniforms: V,
    scratch: Option<StackSlot>,
    mats: Option<StackSlot>,
    ambient: Option<StackSlot>,
    /// Current light samples (innermost last): L and Cl components, visibility (1.0 or
    /// 0.0) and the sample's density (`light.pdf`).
    lights: Vec<(Vec<V>, Vec<V>, V, V)>,
    /// Batch: lanes active in the current arm (`None`: all).
    active: Option<V>,
    /// The carried values of the loops being lowered (innermost last): what `loop.var`
    /// reads, per carried value its components.
    loops: Vec<Vec<Vec<V>>>,
    /// The iterations left to the loop nest being lowered (one per lane in the batch mode),
    /// set at each outermost loop's entry.
    budget: Option<Variable>,
    /// Batch: how many fragments are left from this packet on (its lanes below it hold
    /// fragments; the others are padding, which counts nothing).
    left: Option<V>,
    /// Loads of immutable memory (fragment, uniforms, environment) already emitted, per
    /// block scope (innermost last): each is loaded once per scope.
    loads: Vec<HashMap<LoadKey, V>>,
    /// Each print op's number in the material's print table, by arena index
    /// ([`abi::PrintTable::numbers`], the table's own numbering).
    prints: HashMap<usize, u32>,
}

/// A read of memory that does not change during a call.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum LoadKey {
    /// Component of a stream.
    Stream(Stream, i32),
    /// A uniform slot.
    Uniform(usize),
    /// An environment matrix element.
    Env(usize, usize),
    /// A component of the ambient light.
    Ambient(i32),
}

fn flags() -> MemFlagsData {
    MemFlagsData::new().with_notrap()
}

fn le() -> MemFlagsData {
    MemFlagsData::new().with_endianness(Endianness::Little)
}

type R<T> = Result<T, Unsupported>;

impl<'a, 'b> Lowerer<'a, 'b> {
    /// Starts a function: entry block, parameters, the environment data its ops need.
    pub fn new(
        p: &'a Program,
        mode: Mode,
        mut b: FunctionBuilder<'b>,
        module: &'a mut JITModule,
        helpers: &'a Helpers,
        layout: &'a UniformLayout,
    ) -> Lowerer<'a, 'b> {
        let ptr = module.target_config().pointer_type();
        let entry = b.create_block();
        b.append_block_params_for_function_params(entry);
        b.switch_to_block(entry);
        let params = b.block_params(entry).to_vec();
        let ctx = params[0];
        let frag = params[1];
        let out = params.get(2).copied().unwrap_or(frag);
        let uniforms = b.ins().load(ptr, flags(), ctx, ctx_offset::UNIFORMS);
        Lowerer {
            p,
            mode,
            b,
            module,
            helpers,
            layout,
            ptr,
            vals: vec![Vec::new(); p.exprs.len()],
            regions: HashMap::new(),
            funcs: HashMap::new(),
            ctx,
            frag,
            out,
            uniforms,
            scratch: None,
            mats: None,
            ambient: None,
            lights: Vec::new(),
            active: None,
            loops: Vec::new(),
            budget: None,
            left: None,
            loads: vec![HashMap::new()],
            prints: abi::PrintTable::numbers(p),
        }
    }

    /// Lowers the function's block(s), writes its results, returns, and finalizes.
    pub fn finish(mut self) -> R<()> {
        let p = self.p;
        let block = if self.mode == Mode::Prelude {
            &p.prelude
        } else {
            &p.body
        };
        self.prepare_env(block);
        match self.mode {
            Mode::Prelude => {
                self.block(block)?;
                self.store_prelude()?;
            }
            Mode::Scalar => {
                self.block(block)?;
                let bad = self.store_outputs()?;
                self.b.ins().return_(&[bad]);
            }
            Mode::Batch => self.packet_loop(block)?,
        }
        self.b.seal_all_blocks();
        let cfg = self.module.target_config();
        self.b.finalize(cfg);
        Ok(())
    }

    /// The batch entry's body: the block once per packet, `frag` and `out` advancing by a
    /// packet, the count of fragments left deciding the lanes counted by the guard and when
    /// to stop (a do-while: at least one packet). The environment helpers ran before, once
    /// per call.
    fn packet_loop(&mut self, block: &Block) -> R<()> {
        let params = self
            .b
            .block_params(self.b.func.layout.entry_block().expect("entry"))
            .to_vec();
        let (frag, out, n) = (params[1], params[2], params[3]);
        let (vf, vo, vn, vbad, vfirst) = (
            self.b.declare_var(self.ptr),
            self.b.declare_var(self.ptr),
            self.b.declare_var(I32),
            self.b.declare_var(I32),
            self.b.declare_var(I32),
        );
        let zero = self.b.ins().iconst(I32, 0);
        let first = self.b.ins().load(I32, flags(), self.ctx, ctx_offset::FIRST);
        self.b.def_var(vf, frag);
        self.b.def_var(vo, out);
        self.b.def_var(vn, n);
        self.b.def_var(vbad, zero);
        self.b.def_var(vfirst, first);
        let (body, exit) = (self.b.create_block(), self.b.create_block());
        self.b.ins().jump(body, &[]);
        self.b.switch_to_block(body);
        self.frag = self.b.use_var(vf);
        self.out = self.b.use_var(vo);
        let left = self.b.use_var(vn);
        self.left = Some(left);
        // The scene and message helpers' view of this packet, where the program calls one:
        // its first fragment's index in the batch and how many of its lanes hold fragments.
        let first = self.b.use_var(vfirst);
        if self.asks_scene(block) {
            self.b
                .ins()
                .store(flags(), first, self.ctx, ctx_offset::FIRST);
            let four = self.b.ins().iconst(I32, 4);
            let lanes = self.b.ins().smin(left, four);
            self.b
                .ins()
                .store(flags(), lanes, self.ctx, ctx_offset::LANES);
        }
        self.push_scope();
        self.block(block)?;
        let bad = self.store_outputs()?;
        self.pop_scope();
        let counted = self.count_active(bad, left);
        let acc = self.b.use_var(vbad);
        let acc = self.b.ins().iadd(acc, counted);
        self.b.def_var(vbad, acc);
        let packet = std::mem::size_of::<FragmentX4>() as i64;
        let outs = (self.output_floats() * 16) as i64;
        let f = self.b.ins().iadd_imm_s(self.frag, packet);
        let o = self.b.ins().iadd_imm_s(self.out, outs);
        let rest = self.b.ins().iadd_imm_s(left, -4);
        let next = self.b.ins().iadd_imm_s(first, 4);
        self.b.def_var(vfirst, next);
        self.b.def_var(vf, f);
        self.b.def_var(vo, o);
        self.b.def_var(vn, rest);
        let more = self.b.ins().icmp_imm_s(IntCC::SignedGreaterThan, rest, 0);
        self.b.ins().brif(more, body, &[], exit, &[]);
        self.b.switch_to_block(exit);
        let total = self.b.use_var(vbad);
        self.b.ins().return_(&[total]);
        Ok(())
    }

    /// Whether the block calls a helper that needs to know the packet's fragments: a scene
    /// helper (`trace`, `occlusion`, `light.visible`, `attribute`, `attribute.found`,
    /// `probe`) or a
    /// message helper (`printf`, `warning`, `error`: padding lanes are silent, and each
    /// message is tagged with its fragment).
    fn asks_scene(&self, block: &Block) -> bool {
        let mut asks = false;
        self.p.walk(block, &mut |v| {
            asks |= matches!(
                self.p.op(v),
                Op::Trace { .. }
                    | Op::Occlusion { .. }
                    | Op::LightVisible
                    | Op::Attribute { .. }
                    | Op::AttributeFound { .. }
                    | Op::Probe { .. }
                    | Op::Print { .. }
            )
        });
        asks
    }

    /// The lanes below `left` (the fragments left from this packet on), as an i32x4 mask:
    /// those that hold fragments, not padding.
    fn real_lanes(&mut self, left: V) -> V {
        let lanes = {
            let bytes: Vec<u8> = (0u32..4).flat_map(|i| i.to_le_bytes()).collect();
            let c = self.b.func.dfg.constants.insert(ConstantData::from(bytes));
            self.b.ins().vconst(I32X4, c)
        };
        let nv = self.b.ins().splat(I32X4, left);
        self.b.ins().icmp(IntCC::SignedLessThan, lanes, nv)
    }

    /// The guard's per-lane counts (`bad`, i32x4) summed over the lanes below `left`.
    fn count_active(&mut self, bad: V, left: V) -> V {
        let act = self.real_lanes(left);
        let counted = self.b.ins().band(bad, act);
        let mut t = self.b.ins().extractlane(counted, 0);
        for lane in 1..4u8 {
            let x = self.b.ins().extractlane(counted, lane);
            t = self.b.ins().iadd(t, x);
        }
        t
    }

    /// Floats per fragment in the output (the interpreter's layout).
    fn output_floats(&self) -> usize {
        self.p
            .outputs
            .iter()
            .map(|o| self.ty(o.value).width().max(1))
            .sum()
    }

    // ---- setup ----

    /// Calls the environment helpers once, in the entry block, if the function uses them.
    fn prepare_env(&mut self, block: &Block) {
        let (mut xf, mut amb) = (false, false);
        self.p.walk(block, &mut |v| match self.p.op(v) {
            Op::Transform { from, to, .. } if from != to => xf = true,
            Op::Ambient => amb = true,
            _ => {}
        });
        if xf {
            let ss = self.slot(64 * 4);
            self.call_mem_into("sn_matrices", ss);
            self.mats = Some(ss);
        }
        if amb {
            let ss = self.slot(16);
            self.call_mem_into("sn_ambient", ss);
            self.ambient = Some(ss);
        }
    }

    fn slot(&mut self, bytes: u32) -> StackSlot {
        self.b
            .create_sized_stack_slot(StackSlotData::new(StackSlotKind::ExplicitSlot, bytes, 4))
    }

    fn func(&mut self, id: FuncId) -> FuncRef {
        if let Some(f) = self.funcs.get(&id) {
            return *f;
        }
        let f = self.module.declare_func_in_func(id, self.b.func);
        self.funcs.insert(id, f);
        f
    }

    /// Calls a lane-independent memory helper (scalar version) writing into `ss`.
    fn call_mem_into(&mut self, name: &str, ss: StackSlot) {
        let (id, _) = self.helpers.mem[name];
        let f = self.func(id);
        let out = self.b.ins().stack_addr(self.ptr, ss, 0);
        let zero = self.b.ins().iconst(I32, 0);
        self.b.ins().call(f, &[self.ctx, zero, out, out]);
    }

    // ---- loads of immutable memory, once per scope ----

    fn cached(&mut self, key: LoadKey, load: impl FnOnce(&mut Self) -> V) -> V {
        if let Some(v) = self.loads.iter().rev().find_map(|m| m.get(&key)) {
            return *v;
        }
        let v = load(self);
        if let Some(top) = self.loads.last_mut() {
            top.insert(key, v);
        }
        v
    }

    fn push_scope(&mut self) {
        self.loads.push(HashMap::new());
    }

    fn pop_scope(&mut self) {
        self.loads.pop();
    }

    // ---- representation ----

    fn batch(&self) -> bool {
        self.mode == Mode::Batch
    }

    fn clif_ty(&self, k: Kind) -> ClifType {
        match (self.batch(), k) {
            (false, Kind::F) => F32,
            (false, Kind::I) => I32,
            (false, Kind::B) => I8,
            (true, Kind::F) => F32X4,
            (true, _) => I32X4,
        }
    }

    fn vconst(&mut self, bits: u32) -> V {
        let bytes: Vec<u8> = (0..4).flat_map(|_| bits.to_le_bytes()).collect();
        let c = self.b.func.dfg.constants.insert(ConstantData::from(bytes));
        self.b.ins().vconst(I32X4, c)
    }

    fn fconst(&mut self, x: f32) -> V {
        if self.batch() {
            let bytes: Vec<u8> = (0..4).flat_map(|_| x.to_bits().to_le_bytes()).collect();
            let c = self.b.func.dfg.constants.insert(ConstantData::from(bytes));
            self.b.ins().vconst(F32X4, c)
        } else {
            self.b.ins().f32const(Ieee32::with_bits(x.to_bits()))
        }
    }

    fn iconst(&mut self, x: i32) -> V {
        if self.batch() {
            self.vconst(x as u32)
        } else {
            self.b.ins().iconst(I32, x as i64)
        }
    }

    fn bconst(&mut self, x: bool) -> V {
        if self.batch() {
            self.vconst(if x { u32::MAX } else { 0 })
        } else {
            self.b.ins().iconst(I8, x as i64)
        }
    }

    fn zero(&mut self, k: Kind) -> V {
        match k {
            Kind::F => self.fconst(0.0),
            Kind::I => self.iconst(0),
            Kind::B => self.bconst(false),
        }
    }

    /// A scalar (f32, i32 or i8 bool) made varying: splatted in batch mode.
    fn widen(&mut self, x: V, k: Kind) -> V {
        if !self.batch() {
            return x;
        }
        match k {
            Kind::F => self.b.ins().splat(F32X4, x),
            Kind::I => self.b.ins().splat(I32X4, x),
            Kind::B => {
                let m = self.b.ins().bmask(I32, x);
                self.b.ins().splat(I32X4, m)
            }
        }
    }

    fn load_scalar(&mut self, k: Kind, base: V, offset: i32) -> V {
        let ty = if k == Kind::F { F32 } else { I32 };
        let x = self.b.ins().load(ty, flags(), base, offset);
        if k == Kind::B {
            let b = self.b.ins().icmp_imm_s(IntCC::NotEqual, x, 0);
            self.widen(b, k)
        } else {
            self.widen(x, k)
        }
    }

    /// `c ? a : b` where `c` is a bool in this mode's representation.
    fn sel(&mut self, c: V, a: V, b: V) -> V {
        if !self.batch() {
            return self.b.ins().select(c, a, b);
        }
        if self.b.func.dfg.value_type(a) == F32X4 {
            let m = self.b.ins().bitcast(F32X4, le(), c);
            self.b.ins().bitselect(m, a, b)
        } else {
            self.b.ins().bitselect(c, a, b)
        }
    }

    fn fcmp(&mut self, cc: FloatCC, a: V, b: V) -> V {
        self.b.ins().fcmp(cc, a, b)
    }

    // ---- values ----

    fn unsupported(&self, v: Value, reason: &str) -> Unsupported {
        Unsupported {
            value: v,
            op: format!("{:?} = {}", v, self.p.op(v).short_name()),
            reason: reason.to_string(),
        }
    }

    fn is_remat(&self, v: Value) -> bool {
        match self.p.op(v) {
            Op::Const(_) | Op::Stream(_) | Op::Param(_) => true,
            _ => self.mode != Mode::Prelude && self.layout.prelude.contains_key(&v.index()),
        }
    }

    /// The components of a value (emitting it here if it is rematerialized).
    fn get(&mut self, v: Value) -> R<Vec<V>> {
        if self.is_remat(v) {
            return self.remat(v);
        }
        let x = &self.vals[v.index()];
        if x.is_empty() {
            return Err(self.unsupported(v, "used before it is computed (invalid program)"));
        }
        Ok(x.clone())
    }

    fn ty(&self, v: Value) -> Type {
        self.p.expr(v).ty.unwrap_or(Type::Int)
    }

    fn remat(&mut self, v: Value) -> R<Vec<V>> {
        let ty = self.ty(v);
        let k = kind(ty);
        if self.mode != Mode::Prelude
            && let Some(&slot) = self.layout.prelude.get(&v.index())
        {
            return Ok(self.load_uniform(slot, ty));
        }
        match self.p.op(v) {
            Op::Const(c) => Ok(self.constant(c)),
            Op::Param(i) => {
                let slot = self.layout.params[*i as usize];
                Ok(self.load_uniform(slot, ty))
            }
            Op::Stream(s) => Ok(self.stream_of(*s, k)),
            _ => Err(self.unsupported(v, "not rematerializable")),
        }
    }

    /// The components of a float or int stream (P, ray depth …), loaded once per scope.
    fn stream(&mut self, s: Stream) -> Vec<V> {
        let k = if matches!(s, Stream::RayType | Stream::RayDepth) {
            Kind::I
        } else {
            Kind::F
        };
        self.stream_of(s, k)
    }

    fn stream_of(&mut self, s: Stream, k: Kind) -> Vec<V> {
        let (field, n) = stream_field(s);
        let mut out = Vec::new();
        for c in 0..n {
            let x = self.cached(LoadKey::Stream(s, c), |me| {
                if me.batch() {
                    let ty = me.clif_ty(k);
                    me.b.ins()
                        .load(ty, flags().with_aligned(), me.frag, field.1 + 16 * c)
                } else {
                    let ty = if k == Kind::F { F32 } else { I32 };
                    me.b.ins().load(ty, flags(), me.frag, field.0 + 4 * c)
                }
            });
            out.push(x);
        }
        out
    }

    fn load_uniform(&mut self, slot: usize, ty: Type) -> Vec<V> {
        let k = kind(ty);
        let base = self.uniforms;
        (0..comps(ty))
            .map(|c| {
                self.cached(LoadKey::Uniform(slot + c), |me| {
                    me.load_scalar(k, base, ((slot + c) * 4) as i32)
                })
            })
            .collect()
    }

    fn constant(&mut self, c: &ConstValue) -> Vec<V> {
        match c {
            ConstValue::Bool(b) => vec![self.bconst(*b)],
            ConstValue::Int(i) => vec![self.iconst(*i)],
            ConstValue::String(_) => vec![self.iconst(0)],
            ConstValue::Float(x) => vec![self.fconst(*x as f32)],
            ConstValue::Vec2(v) => v.iter().map(|x| self.fconst(*x as f32)).collect(),
            ConstValue::Vec3(v) | ConstValue::Color(v) => {
                v.iter().map(|x| self.fconst(*x as f32)).collect()
            }
            ConstValue::Vec4(v) | ConstValue::Color4(v) => {
                v.iter().map(|x| self.fconst(*x as f32)).collect()
            }
            ConstValue::Matrix33(m) => m.iter().map(|x| self.fconst(*x as f32)).collect(),
            ConstValue::Matrix44(m) => m.iter().map(|x| self.fconst(*x as f32)).collect(),
        }
    }

    fn block(&mut self, block: &Block) -> R<()> {
        for &v in &block.body {
            if self.is_remat(v) {
                continue;
            }
            let x = self.value(v)?;
            self.vals[v.index()] = x;
        }
        Ok(())
    }

    fn value(&mut self, v: Value) -> R<Vec<V>> {
        let p = self.p;
        let ty = p.expr(v).ty;
        match p.op(v) {
            Op::Const(_) | Op::Param(_) | Op::Stream(_) => self.remat(v),
            Op::Transform {
                kind: xk,
                from,
                to,
                arg,
            } => {
                let a = self.get(*arg)?;
                Ok(self.transform(*xk, *from, *to, a))
            }
            Op::ComponentEnabled(k) => {
                let mask = self.b.ins().load(I32, flags(), self.ctx, ctx_offset::MASK);
                let bit = self
                    .b
                    .ins()
                    .band_imm_s(mask, (1u32 << (*k as u32 & 31)) as i32 as i64);
                let on = self.b.ins().icmp_imm_s(IntCC::NotEqual, bit, 0);
                Ok(vec![self.widen(on, Kind::B)])
            }
            Op::Unary(op, a) => {
                let at = self.ty(*a);
                let x = self.get(*a)?;
                self.unary(v, *op, at, x)
            }
            Op::Binary(op, a, b) => {
                let at = self.ty(*a);
                let x = self.get(*a)?;
                let y = self.get(*b)?;
                self.binary(v, *op, at, x, y)
            }
            Op::Select { cond, a, b } => {
                let c = self.get(*cond)?[0];
                let x = self.get(*a)?;
                let y = self.get(*b)?;
                Ok(x.into_iter()
                    .zip(y)
                    .map(|(x, y)| self.sel(c, x, y))
                    .collect())
            }
            Op::Construct(args) => {
                let mut out = Vec::new();
                for a in args {
                    out.push(self.get(*a)?[0]);
                }
                Ok(out)
            }
            Op::Extract(a, i) => {
                let x = self.get(*a)?;
                Ok(vec![x[*i as usize]])
            }
            Op::Splat(a) => {
                let x = self.get(*a)?[0];
                Ok(vec![x; comps(ty.unwrap_or(Type::Vec3))])
            }
            Op::Convert(a) => {
                let from = self.ty(*a);
                let x = self.get(*a)?[0];
                Ok(vec![self.convert(from, ty.unwrap_or(Type::Float), x)])
            }
            Op::Call(i, args) => {
                let mut xs = Vec::new();
                for a in args {
                    xs.extend(self.get(*a)?);
                }
                let (name, outs) = match i {
                    Intrinsic::Noise2 => ("sn_noise2", 1),
                    Intrinsic::Noise3 => ("sn_noise3", 1),
                    Intrinsic::Fbm3 => ("sn_fbm3", 1),
                    Intrinsic::CellNoise3 => ("sn_cellnoise3", 1),
                    Intrinsic::RgbToHsv => ("sn_rgb_to_hsv", 3),
                    Intrinsic::HsvToRgb => ("sn_hsv_to_rgb", 3),
                    osl => {
                        let h = abi::mem_helper(&format!("sn_{}", osl.name()))
                            .ok_or_else(|| self.unsupported(v, "an intrinsic without a helper"))?;
                        (h.name, h.outs)
                    }
                };
                let imm = self.b.ins().iconst(I32, 0);
                Ok(self.call_mem(name, imm, &xs, outs))
            }
            Op::Texture {
                texture,
                uv,
                derivs,
                sampling,
                alpha,
            } => {
                let mut xs = self.get(*uv)?;
                match derivs {
                    Some([dx, dy]) => {
                        xs.extend(self.get(*dx)?);
                        xs.extend(self.get(*dy)?);
                    }
                    None => xs.extend([self.fconst(0.0); 4]),
                }
                let imm = abi::texture_imm(*texture, *sampling)
                    .ok_or_else(|| self.unsupported(v, "more than 2^24 textures"))?;
                let imm = self.b.ins().iconst(I32, imm as i64);
                let t = self.call_mem("sn_texture", imm, &xs, 4);
                Ok(if *alpha { vec![t[3]] } else { t[..3].to_vec() })
            }
            Op::LightPdf => match self.lights.last() {
                Some((_, _, _, pdf)) => Ok(vec![*pdf]),
                None => Ok(vec![self.fconst(0.0)]),
            },
            Op::LightL | Op::LightCl => match self.lights.last() {
                Some((l, cl, _, _)) => Ok(if matches!(p.op(v), Op::LightL) {
                    l.clone()
                } else {
                    cl.clone()
                }),
                None => Ok(vec![self.fconst(0.0); 3]),
            },
            Op::LightVisible => match self.lights.last() {
                Some((_, _, vis, _)) => Ok(vec![*vis]),
                None => Ok(vec![self.fconst(1.0)]),
            },
            Op::Ambient => {
                let ss = self
                    .ambient
                    .ok_or_else(|| self.unsupported(v, "no ambient slot"))?;
                let mut out = Vec::new();
                for c in 0..3 {
                    let x = self.cached(LoadKey::Ambient(c), |me| {
                        let x = me.b.ins().stack_load(me.ptr, F32, ss, c * 4);
                        me.widen(x, Kind::F)
                    });
                    out.push(x);
                }
                Ok(out)
            }
            Op::Proj(r, k) => {
                let res = self
                    .regions
                    .get(&r.index())
                    .and_then(|rs| rs.get(*k as usize))
                    .cloned();
                res.ok_or_else(|| self.unsupported(v, "projection of an unknown region"))
            }
            Op::If { cond, then_, else_ } => {
                let c = self.get(*cond)?[0];
                let res = if self.batch() {
                    self.if_batch(v, c, then_, else_)?
                } else {
                    self.if_scalar(v, c, then_, else_)?
                };
                self.regions.insert(v.index(), res);
                Ok(Vec::new())
            }
            Op::Loop { init, cond, body } => {
                let res = self.loop_(v, init, cond, body)?;
                self.regions.insert(v.index(), res);
                Ok(Vec::new())
            }
            Op::LoopVar(k) => {
                let cur = self.loops.last().and_then(|c| c.get(*k as usize)).cloned();
                cur.ok_or_else(|| self.unsupported(v, "loop.var outside a loop (invalid program)"))
            }
            Op::Illuminance { p: point, body } => {
                let pt = self.get(*point)?;
                let res = self.illuminance(v, pt, body)?;
                self.regions.insert(v.index(), res);
                Ok(Vec::new())
            }
            Op::Trace { dir, ray_type, pdf } => {
                let mut args = self.get(*dir)?;
                args.extend(self.stream(Stream::P));
                args.extend(self.stream(Stream::RayDepth));
                let pdf = match pdf {
                    Some(p) => self.get(*p)?[0],
                    None => self.fconst(0.0),
                };
                args.push(pdf);
                let imm = self.b.ins().iconst(I32, *ray_type as i64);
                Ok(self.call_mem("sn_trace", imm, &args, 3))
            }
            Op::Attribute { slot, default } => {
                let mut args = self.get(*default)?;
                let width = args.len();
                let imm = abi::attribute_imm(*slot, width)
                    .ok_or_else(|| self.unsupported(v, "more than 2^24 attributes"))?;
                args.resize(4, self.fconst(0.0));
                let imm = self.b.ins().iconst(I32, imm as i64);
                let mut got = self.call_mem("sn_attribute", imm, &args, 4);
                got.truncate(width);
                Ok(got)
            }
            Op::AttributeFound { slot } => {
                let width = self.p.attributes[*slot as usize].ty.width();
                let imm = abi::attribute_imm(*slot, width)
                    .ok_or_else(|| self.unsupported(v, "more than 2^24 attributes"))?;
                let imm = self.b.ins().iconst(I32, imm as i64);
                let found = self.call_mem("sn_attribute_found", imm, &[], 1)[0];
                let zero = self.fconst(0.0);
                Ok(vec![self.fcmp(FloatCC::NotEqual, found, zero)])
            }
            Op::Occlusion {
                n,
                samples,
                max_distance,
            } => {
                let mut args = self.get(*n)?;
                args.push(self.get(*samples)?[0]);
                args.push(self.get(*max_distance)?[0]);
                args.extend(self.stream(Stream::P));
                args.push(self.seed());
                let imm = self.b.ins().iconst(I32, 0);
                Ok(self.call_mem("sn_occlusion", imm, &args, 1))
            }
            Op::Print { args, .. } => self.print(v, args),
            Op::Probe {
                field,
                origin,
                dir,
                min_distance,
                max_distance,
            } => {
                let mut args = self.get(*origin)?;
                args.extend(self.get(*dir)?);
                args.push(self.get(*min_distance)?[0]);
                args.push(self.get(*max_distance)?[0]);
                let code = ProbeField::ALL.iter().position(|f| f == field).unwrap_or(0);
                let imm = self.b.ins().iconst(I32, code as i64);
                let mut got = self.call_mem("sn_probe", imm, &args, 3);
                got.truncate(field.ty().width());
                Ok(got)
            }
        }
    }

    /// A print op: its argument components stored as 32-bit words in a slot of their own
    /// (batch: after the active lane mask, four lanes per word), then the message helper
    /// (`abi/print.rs`), with the op's number in the material's print table. Its value is
    /// the int 0.
    fn print(&mut self, v: Value, args: &[Value]) -> R<Vec<V>> {
        let Some(&index) = self.prints.get(&v.index()) else {
            return Err(self.unsupported(v, "a print op the print table does not hold"));
        };
        let mut words = Vec::new();
        if self.batch() {
            let mask = match self.active {
                Some(m) => m,
                None => self.iconst(-1),
            };
            words.push(mask);
        }
        for a in args {
            let bool_arg = self.ty(*a) == Type::Bool;
            for x in self.get(*a)? {
                words.push(if bool_arg && !self.batch() {
                    self.b.ins().uextend(I32, x)
                } else {
                    x
                });
            }
        }
        let esize = if self.batch() { 16 } else { 4 };
        let ss = self.slot((words.len().max(1) * esize) as u32);
        for (k, w) in words.iter().enumerate() {
            self.b
                .ins()
                .stack_store(self.ptr, *w, ss, (k * esize) as i32);
        }
        let (s, bt) = self.helpers.print;
        let f = self.func(if self.batch() { bt } else { s });
        let index = self.b.ins().iconst(I32, index as i64);
        let addr = self.b.ins().stack_addr(self.ptr, ss, 0);
        self.b.ins().call(f, &[self.ctx, index, addr]);
        Ok(vec![self.iconst(0)])
    }

    // ---- regions ----

    fn yield_kinds(&self, _region: Value, block: &Block) -> R<Vec<(Kind, usize)>> {
        let mut ks = Vec::new();
        for y in &block.yields {
            let t = self.ty(*y);
            ks.push((kind(t), comps(t)));
        }
        Ok(ks)
    }

    fn yields(&mut self, block: &Block) -> R<Vec<V>> {
        let mut out = Vec::new();
        for y in &block.yields {
            out.extend(self.get(*y)?);
        }
        Ok(out)
    }

    fn regroup(ks: &[(Kind, usize)], flat: &[V]) -> Vec<Vec<V>> {
        let mut out = Vec::new();
        let mut i = 0;
        for (_, n) in ks {
            out.push(flat[i..i + n].to_vec());
            i += n;
        }
        out
    }

    fn merge_block(&mut self, ks: &[(Kind, usize)]) -> cranelift_codegen::ir::Block {
        let blk = self.b.create_block();
        for (k, n) in ks {
            let ty = self.clif_ty(*k);
            for _ in 0..*n {
                self.b.append_block_param(blk, ty);
            }
        }
        blk
    }

    fn zeros(&mut self, ks: &[(Kind, usize)]) -> Vec<BlockArg> {
        let mut out = Vec::new();
        for (k, n) in ks {
            for _ in 0..*n {
                let z = self.zero(*k);
                out.push(BlockArg::Value(z));
            }
        }
        out
    }

    fn args(xs: &[V]) -> Vec<BlockArg> {
        xs.iter().map(|x| BlockArg::Value(*x)).collect()
    }

    fn if_scalar(&mut self, v: Value, c: V, then_: &Block, else_: &Block) -> R<Vec<Vec<V>>> {
        let ks = self.yield_kinds(v, then_)?;
        let tb = self.b.create_block();
        let eb = self.b.create_block();
        let merge = self.merge_block(&ks);
        self.b.ins().brif(c, tb, &[], eb, &[]);
        self.b.switch_to_block(tb);
        self.push_scope();
        self.block(then_)?;
        let ty = self.yields(then_)?;
        self.pop_scope();
        self.b.ins().jump(merge, &Self::args(&ty));
        self.b.switch_to_block(eb);
        self.push_scope();
        self.block(else_)?;
        let ey = self.yields(else_)?;
        self.pop_scope();
        self.b.ins().jump(merge, &Self::args(&ey));
        self.b.switch_to_block(merge);
        let res = self.b.block_params(merge).to_vec();
        Ok(Self::regroup(&ks, &res))
    }

    fn if_batch(&mut self, v: Value, m: V, then_: &Block, else_: &Block) -> R<Vec<Vec<V>>> {
        let ks = self.yield_kinds(v, then_)?;
        let outer = self.active;
        let (tm, em) = match outer {
            Some(a) => (self.b.ins().band(a, m), self.b.ins().band_not(a, m)),
            None => (m, self.b.ins().bnot(m)),
        };
        // Then arm, if any active lane takes it.
        let any_t = self.b.ins().vany_true(tm);
        let tb = self.b.create_block();
        let after_then = self.merge_block(&ks);
        let z = self.zeros(&ks);
        self.b.ins().brif(any_t, tb, &[], after_then, &z);
        self.b.switch_to_block(tb);
        self.active = Some(tm);
        self.push_scope();
        self.block(then_)?;
        let ty = self.yields(then_)?;
        self.pop_scope();
        self.b.ins().jump(after_then, &Self::args(&ty));
        self.b.switch_to_block(after_then);
        let tv = self.b.block_params(after_then).to_vec();
        // Else arm, if any active lane takes it.
        self.active = outer;
        let any_e = self.b.ins().vany_true(em);
        let eb = self.b.create_block();
        let merge = self.merge_block(&ks);
        let z = self.zeros(&ks);
        self.b.ins().brif(any_e, eb, &[], merge, &z);
        self.b.switch_to_block(eb);
        self.active = Some(em);
        self.push_scope();
        self.block(else_)?;
        let ey = self.yields(else_)?;
        self.pop_scope();
        self.b.ins().jump(merge, &Self::args(&ey));
        self.b.switch_to_block(merge);
        self.active = outer;
        let ev = self.b.block_params(merge).to_vec();
        // Blend per lane.
        let res: Vec<V> = tv
            .iter()
            .zip(&ev)
            .map(|(t, e)| self.sel(m, *t, *e))
            .collect();
        Ok(Self::regroup(&ks, &res))
    }

    /// The light loop: a CLIF loop over the environment's lights; each iteration calls the
    /// light helper (`runtime::lights::sample`), skips lights without a sample (ambient),
    /// runs the body and adds its yields to the sums.
    fn illuminance(&mut self, v: Value, pt: Vec<V>, body: &Block) -> R<Vec<Vec<V>>> {
        let ks = self.yield_kinds(v, body)?;
        let mut sums: Vec<(Variable, Kind)> = Vec::new();
        for (k, n) in &ks {
            for _ in 0..*n {
                let ty = self.clif_ty(*k);
                let var = self.b.declare_var(ty);
                let z = self.zero(*k);
                self.b.def_var(var, z);
                sums.push((var, *k));
            }
        }
        let i_var = self.b.declare_var(I32);
        let zero = self.b.ins().iconst(I32, 0);
        self.b.def_var(i_var, zero);
        let n = self
            .b
            .ins()
            .load(I32, flags(), self.ctx, ctx_offset::N_LIGHTS);
        let header = self.b.create_block();
        let sample = self.b.create_block();
        let body_blk = self.b.create_block();
        let next = self.b.create_block();
        let exit = self.b.create_block();
        self.b.ins().jump(header, &[]);

        self.b.switch_to_block(header);
        let i = self.b.use_var(i_var);
        let more = self.b.ins().icmp(IntCC::UnsignedLessThan, i, n);
        self.b.ins().brif(more, sample, &[], exit, &[]);

        self.b.switch_to_block(sample);
        // The fragment's sampler seed rides along as the bits of a fourth float.
        let seed = self.seed();
        let mut args = pt.clone();
        args.push(seed);
        let out = self.call_mem("sn_light", i, &args, 11);
        // Whether the light gives a sample is the same for every lane: read lane 0.
        let flag = if self.batch() {
            self.b.ins().extractlane(out[6], 0)
        } else {
            out[6]
        };
        let zf = self.b.ins().f32const(Ieee32::with_bits(0));
        let ok = self.b.ins().fcmp(FloatCC::NotEqual, flag, zf);
        self.b.ins().brif(ok, body_blk, &[], next, &[]);

        self.b.switch_to_block(body_blk);
        // Shadow test, as the interpreter: only for a body that reads `light.visible`, and
        // once per sample slot `i` and call at the same point (the helper's memo: another
        // light loop at the point gets the answer without a second shadow ray).
        let mut reads_visible = false;
        self.p.walk(body, &mut |x| {
            reads_visible |= *self.p.op(x) == Op::LightVisible
        });
        let vis = if reads_visible {
            let mut args = pt.clone();
            args.extend_from_slice(&out[7..10]);
            self.call_mem("sn_visible", i, &args, 1)[0]
        } else {
            self.fconst(1.0)
        };
        self.lights
            .push((out[0..3].to_vec(), out[3..6].to_vec(), vis, out[10]));
        self.push_scope();
        self.block(body)?;
        let ys = self.yields(body)?;
        self.pop_scope();
        self.lights.pop();
        for ((var, k), y) in sums.iter().zip(ys) {
            let s = self.b.use_var(*var);
            let s2 = match k {
                Kind::F => self.b.ins().fadd(s, y),
                _ => self.b.ins().iadd(s, y),
            };
            self.b.def_var(*var, s2);
        }
        self.b.ins().jump(next, &[]);

        self.b.switch_to_block(next);
        let i = self.b.use_var(i_var);
        let i2 = self.b.ins().iadd_imm_s(i, 1);
        self.b.def_var(i_var, i2);
        self.b.ins().jump(header, &[]);

        self.b.switch_to_block(exit);
        let res: Vec<V> = sums.iter().map(|(var, _)| self.b.use_var(*var)).collect();
        Ok(Self::regroup(&ks, &res))
    }

    /// The fragment's sampler seed as the bits of a float (a vector of them in batch mode).
    fn seed(&mut self) -> V {
        if self.batch() {
            let off = offset_of!(FragmentX4, seed) as i32;
            self.b.ins().load(F32X4, flags(), self.frag, off)
        } else {
            let off = offset_of!(Fragment, seed) as i32;
            self.b.ins().load(F32, flags(), self.frag, off)
        }
    }

    // ---- helper calls ----

    fn scratch(&mut self) -> StackSlot {
        match self.scratch {
            Some(s) => s,
            None => {
                let s = self.slot(SCRATCH_BYTES);
                self.scratch = Some(s);
                s
            }
        }
    }

    /// Calls a memory helper with `args` (components; ints as their bits) and returns `outs`
    /// float components.
    fn call_mem(&mut self, name: &str, imm: V, args: &[V], outs: usize) -> Vec<V> {
        let ss = self.scratch();
        let esize = if self.batch() { 16 } else { 4 };
        for (k, a) in args.iter().enumerate() {
            self.b
                .ins()
                .stack_store(self.ptr, *a, ss, (k * esize) as i32);
        }
        let (s, bt) = self.helpers.mem[name];
        let f = self.func(if self.batch() { bt } else { s });
        let pa = self.b.ins().stack_addr(self.ptr, ss, 0);
        let po = self.b.ins().stack_addr(self.ptr, ss, SCRATCH_ARGS as i32);
        self.b.ins().call(f, &[self.ctx, imm, pa, po]);
        let ty = self.clif_ty(Kind::F);
        (0..outs)
            .map(|k| {
                self.b
                    .ins()
                    .stack_load(self.ptr, ty, ss, SCRATCH_ARGS as i32 + (k * esize) as i32)
            })
            .collect()
    }

    /// Calls a math helper: the scalar function (scalar), or the four-lane one once per
    /// packet with the arguments' lanes in the scratch slot (batch; with
    /// `SHADENET_SIMD=lanes` the scalar one once per lane instead).
    fn call_math(&mut self, name: &'static str, args: &[V]) -> V {
        let (scalar, x4) = self.helpers.math[name];
        if self.batch() && abi::math_x4_enabled() {
            let ss = self.scratch();
            for (k, a) in args.iter().enumerate() {
                self.b.ins().stack_store(self.ptr, *a, ss, (k * 16) as i32);
            }
            let f = self.func(x4);
            let pa = self.b.ins().stack_addr(self.ptr, ss, 0);
            let po = self.b.ins().stack_addr(self.ptr, ss, SCRATCH_ARGS as i32);
            self.b.ins().call(f, &[pa, po]);
            return self
                .b
                .ins()
                .stack_load(self.ptr, F32X4, ss, SCRATCH_ARGS as i32);
        }
        let f = self.func(scalar);
        if !self.batch() {
            let inst = self.b.ins().call(f, args);
            return self.b.inst_results(inst)[0];
        }
        let mut acc = None;
        for lane in 0..4u8 {
            let xs: Vec<V> = args
                .iter()
                .map(|a| self.b.ins().extractlane(*a, lane))
                .collect();
            let inst = self.b.ins().call(f, &xs);
            let r = self.b.inst_results(inst)[0];
            acc = Some(match acc {
                None => self.b.ins().splat(F32X4, r),
                Some(a) => self.b.ins().insertlane(a, r, lane),
            });
        }
        acc.unwrap_or_else(|| self.fconst(0.0))
    }

    // ---- arithmetic (ops.rs, op for op) ----

    fn div(&mut self, a: V, b: V) -> V {
        let z = self.fconst(0.0);
        let q = self.b.ins().fdiv(a, b);
        let is0 = self.fcmp(FloatCC::Equal, b, z);
        self.sel(is0, z, q)
    }

    fn sqrt(&mut self, x: V) -> V {
        let z = self.fconst(0.0);
        let r = self.b.ins().sqrt(x);
        let neg = self.fcmp(FloatCC::LessThan, x, z);
        self.sel(neg, z, r)
    }

    fn fmod(&mut self, a: V, b: V) -> V {
        let z = self.fconst(0.0);
        let q = self.b.ins().fdiv(a, b);
        let f = self.b.ins().floor(q);
        let m = self.b.ins().fmul(b, f);
        let r = self.b.ins().fsub(a, m);
        let is0 = self.fcmp(FloatCC::Equal, b, z);
        self.sel(is0, z, r)
    }

    fn dot(&mut self, a: &[V], b: &[V]) -> V {
        let mut s = self.fconst(0.0);
        for (x, y) in a.iter().zip(b) {
            let m = self.b.ins().fmul(*x, *y);
            s = self.b.ins().fadd(s, m);
        }
        s
    }

    fn length(&mut self, a: &[V]) -> V {
        let d = self.dot(a, a);
        self.sqrt(d)
    }

    fn unary(&mut self, v: Value, op: UnOp, at: Type, x: Vec<V>) -> R<Vec<V>> {
        use UnOp::*;
        match kind(at) {
            Kind::B => {
                let r = match op {
                    Not if self.batch() => self.b.ins().bnot(x[0]),
                    Not => self.b.ins().bxor_imm_s(x[0], 1),
                    _ => x[0],
                };
                return Ok(vec![r]);
            }
            Kind::I => {
                let r = match op {
                    Neg => self.b.ins().ineg(x[0]),
                    Abs => self.b.ins().iabs(x[0]),
                    BitNot => self.b.ins().bnot(x[0]),
                    _ => x[0],
                };
                return Ok(vec![r]);
            }
            Kind::F => {}
        }
        match op {
            Length => return Ok(vec![self.length(&x)]),
            Normalize => {
                let l = self.length(&x);
                return Ok(x.iter().map(|c| self.div(*c, l)).collect());
            }
            Not => return Err(self.unsupported(v, "not on a float")),
            _ => {}
        }
        let mut out = Vec::new();
        for c in x {
            let r = match op {
                Neg => self.b.ins().fneg(c),
                Abs => self.b.ins().fabs(c),
                Floor => self.b.ins().floor(c),
                Ceil => self.b.ins().ceil(c),
                Fract => {
                    let f = self.b.ins().floor(c);
                    self.b.ins().fsub(c, f)
                }
                Sqrt => self.sqrt(c),
                Exp => self.call_math("sn_exp", &[c]),
                Log => self.call_math("sn_log", &[c]),
                Sin => self.call_math("sn_sin", &[c]),
                Cos => self.call_math("sn_cos", &[c]),
                Tan => self.call_math("sn_tan", &[c]),
                Asin => self.call_math("sn_asin", &[c]),
                Acos => self.call_math("sn_acos", &[c]),
                Not | Length | Normalize | BitNot => c,
            };
            out.push(r);
        }
        Ok(out)
    }

    fn binary(&mut self, v: Value, op: BinOp, at: Type, x: Vec<V>, y: Vec<V>) -> R<Vec<V>> {
        use BinOp::*;
        match op {
            MulPoint | MulVector => {
                let (m, p) = (x, y);
                let mut out = Vec::new();
                for r in 0..3 {
                    let a = self.b.ins().fmul(m[r * 4], p[0]);
                    let b = self.b.ins().fmul(m[r * 4 + 1], p[1]);
                    let s = self.b.ins().fadd(a, b);
                    let c = self.b.ins().fmul(m[r * 4 + 2], p[2]);
                    let s = self.b.ins().fadd(s, c);
                    out.push(if op == MulPoint {
                        self.b.ins().fadd(s, m[r * 4 + 3])
                    } else {
                        s
                    });
                }
                return Ok(out);
            }
            _ => {}
        }
        match kind(at) {
            Kind::I => return Ok(vec![self.int_binary(v, op, x[0], y[0])?]),
            Kind::B => {
                let (a, b) = (x[0], y[0]);
                let r = match op {
                    And => self.b.ins().band(a, b),
                    Or => self.b.ins().bor(a, b),
                    Eq => self.b.ins().icmp(IntCC::Equal, a, b),
                    Ne => self.b.ins().icmp(IntCC::NotEqual, a, b),
                    _ => return Err(self.unsupported(v, "not defined on bools")),
                };
                return Ok(vec![r]);
            }
            Kind::F => {}
        }
        let cmp = |op: BinOp| match op {
            Lt => Some(FloatCC::LessThan),
            Le => Some(FloatCC::LessThanOrEqual),
            Gt => Some(FloatCC::GreaterThan),
            Ge => Some(FloatCC::GreaterThanOrEqual),
            Eq => Some(FloatCC::Equal),
            Ne => Some(FloatCC::NotEqual),
            _ => None,
        };
        if let Some(cc) = cmp(op) {
            return Ok(vec![self.fcmp(cc, x[0], y[0])]);
        }
        match op {
            Dot => return Ok(vec![self.dot(&x, &y)]),
            Distance => {
                let d: Vec<V> = x
                    .iter()
                    .zip(&y)
                    .map(|(a, b)| self.b.ins().fsub(*a, *b))
                    .collect();
                return Ok(vec![self.length(&d)]);
            }
            Cross => {
                let (a, b) = (x, y);
                let mut out = Vec::new();
                for (i, j) in [(1, 2), (2, 0), (0, 1)] {
                    let p = self.b.ins().fmul(a[i], b[j]);
                    let q = self.b.ins().fmul(a[j], b[i]);
                    out.push(self.b.ins().fsub(p, q));
                }
                return Ok(out);
            }
            And | Or => return Err(self.unsupported(v, "not defined on floats")),
            _ => {}
        }
        let mut out = Vec::new();
        for (a, b) in x.into_iter().zip(y) {
            let r = match op {
                Add => self.b.ins().fadd(a, b),
                Sub => self.b.ins().fsub(a, b),
                Mul => self.b.ins().fmul(a, b),
                Div => self.div(a, b),
                Mod => self.fmod(a, b),
                Pow => self.call_math("sn_pow", &[a, b]),
                Atan2 => self.call_math("sn_atan2", &[a, b]),
                Min => {
                    let lt = self.fcmp(FloatCC::LessThan, a, b);
                    self.sel(lt, a, b)
                }
                Max => {
                    let gt = self.fcmp(FloatCC::GreaterThan, a, b);
                    self.sel(gt, a, b)
                }
                _ => return Err(self.unsupported(v, "not a component-wise float op")),
            };
            out.push(r);
        }
        Ok(out)
    }

    fn int_binary(&mut self, v: Value, op: BinOp, a: V, b: V) -> R<V> {
        use BinOp::*;
        let icmp = |cc| Some(cc);
        let cc = match op {
            Lt => icmp(IntCC::SignedLessThan),
            Le => icmp(IntCC::SignedLessThanOrEqual),
            Gt => icmp(IntCC::SignedGreaterThan),
            Ge => icmp(IntCC::SignedGreaterThanOrEqual),
            Eq => icmp(IntCC::Equal),
            Ne => icmp(IntCC::NotEqual),
            _ => None,
        };
        if let Some(cc) = cc {
            return Ok(self.b.ins().icmp(cc, a, b));
        }
        Ok(match op {
            Add => self.b.ins().iadd(a, b),
            Sub => self.b.ins().isub(a, b),
            Mul => self.b.ins().imul(a, b),
            Min => self.b.ins().smin(a, b),
            Max => self.b.ins().smax(a, b),
            BitAnd => self.b.ins().band(a, b),
            BitOr => self.b.ins().bor(a, b),
            BitXor => self.b.ins().bxor(a, b),
            Div | Mod | Shl | Shr => {
                // Cranelift has neither vector division nor per-lane shift counts: lane by
                // lane in the batch entry.
                if !self.batch() {
                    return Ok(self.int_scalar_op(op, a, b));
                }
                let mut acc = None;
                for lane in 0..4u8 {
                    let x = self.b.ins().extractlane(a, lane);
                    let y = self.b.ins().extractlane(b, lane);
                    let r = self.int_scalar_op(op, x, y);
                    acc = Some(match acc {
                        None => self.b.ins().splat(I32X4, r),
                        Some(acc) => self.b.ins().insertlane(acc, r, lane),
                    });
                }
                acc.unwrap_or(a)
            }
            _ => return Err(self.unsupported(v, "not defined on ints")),
        })
    }

    /// One lane of `Div`, `Mod`, `Shl` or `Shr` on scalar i32s.
    fn int_scalar_op(&mut self, op: BinOp, a: V, b: V) -> V {
        match op {
            // The count's low five bits, as `ops::binary` (Cranelift masks it too; stated
            // so the code says what it relies on).
            BinOp::Shl | BinOp::Shr => {
                let n = self.b.ins().band_imm_s(b, 31);
                if op == BinOp::Shl {
                    self.b.ins().ishl(a, n)
                } else {
                    self.b.ins().sshr(a, n)
                }
            }
            _ => self.int_divmod(op == BinOp::Div, a, b),
        }
    }

    /// Scalar i32 `wrapping_div` / `wrapping_rem_euclid`, 0 for a zero divisor, never a trap.
    fn int_divmod(&mut self, div: bool, a: V, b: V) -> V {
        let zero = self.b.ins().iconst(I32, 0);
        let one = self.b.ins().iconst(I32, 1);
        let is0 = self.b.ins().icmp_imm_s(IntCC::Equal, b, 0);
        let is_m1 = self.b.ins().icmp_imm_s(IntCC::Equal, b, -1);
        let bad = self.b.ins().bor(is0, is_m1);
        let safe_b = self.b.ins().select(bad, one, b);
        let r = if div {
            let q = self.b.ins().sdiv(a, safe_b);
            let neg = self.b.ins().ineg(a);
            self.b.ins().select(is_m1, neg, q)
        } else {
            let r = self.b.ins().srem(a, safe_b);
            let abs_b = self.b.ins().iabs(b);
            let fixed = self.b.ins().iadd(r, abs_b);
            let rneg = self.b.ins().icmp_imm_s(IntCC::SignedLessThan, r, 0);
            let r = self.b.ins().select(rneg, fixed, r);
            self.b.ins().select(is_m1, zero, r)
        };
        self.b.ins().select(is0, zero, r)
    }

    fn convert(&mut self, from: Type, to: Type, x: V) -> V {
        let (fk, tk) = (kind(from), kind(to));
        let batch = self.batch();
        match (fk, tk) {
            (a, b) if a == b => x,
            (Kind::B, Kind::I) => {
                if batch {
                    self.b.ins().ushr_imm_s(x, 31)
                } else {
                    self.b.ins().uextend(I32, x)
                }
            }
            (Kind::B, Kind::F) => {
                if batch {
                    let one = self.vconst(1.0f32.to_bits());
                    let bits = self.b.ins().band(x, one);
                    self.b.ins().bitcast(F32X4, le(), bits)
                } else {
                    let i = self.b.ins().uextend(I32, x);
                    self.b.ins().fcvt_from_sint(F32, i)
                }
            }
            (Kind::I, Kind::F) => {
                let ty = self.clif_ty(Kind::F);
                self.b.ins().fcvt_from_sint(ty, x)
            }
            (Kind::F, Kind::I) => {
                let ty = self.clif_ty(Kind::I);
                self.b.ins().fcvt_to_sint_sat(ty, x)
            }
            (Kind::I, Kind::B) => {
                let z = self.iconst(0);
                self.b.ins().icmp(IntCC::NotEqual, x, z)
            }
            (Kind::F, Kind::B) => {
                let z = self.fconst(0.0);
                self.fcmp(FloatCC::NotEqual, x, z)
            }
            _ => x,
        }
    }

    /// One matrix element of the environment (`which`: 0 camera m, 1 camera inverse, 2
    /// object m, 3 object inverse).
    fn env_elem(&mut self, which: usize, e: usize) -> V {
        let ss = self.mats.expect("matrices prepared for transforms");
        self.cached(LoadKey::Env(which, e), |me| {
            let x =
                me.b.ins()
                    .stack_load(me.ptr, F32, ss, ((which * 16 + e) * 4) as i32);
            me.widen(x, Kind::F)
        })
    }

    /// `ops::transform(kind, m, m_inv, v)` with `m` and `m_inv` environment matrices.
    fn apply(&mut self, k: XformKind, m: usize, m_inv: usize, v: &[V]) -> Vec<V> {
        let mut out = Vec::new();
        for r in 0..3 {
            let idx: [usize; 4] = match k {
                XformKind::Normal => [r, 4 + r, 8 + r, 0],
                _ => [r * 4, r * 4 + 1, r * 4 + 2, r * 4 + 3],
            };
            let which = if k == XformKind::Normal { m_inv } else { m };
            let e0 = self.env_elem(which, idx[0]);
            let e1 = self.env_elem(which, idx[1]);
            let e2 = self.env_elem(which, idx[2]);
            let a = self.b.ins().fmul(e0, v[0]);
            let b = self.b.ins().fmul(e1, v[1]);
            let s = self.b.ins().fadd(a, b);
            let c = self.b.ins().fmul(e2, v[2]);
            let s = self.b.ins().fadd(s, c);
            out.push(if k == XformKind::Point {
                let e3 = self.env_elem(which, idx[3]);
                self.b.ins().fadd(s, e3)
            } else {
                s
            });
        }
        out
    }

    /// `runtime::interp::transform`: `from` → world → `to`.
    fn transform(&mut self, k: XformKind, from: Space, to: Space, v: Vec<V>) -> Vec<V> {
        if from == to {
            return v;
        }
        let base = |s: Space| match s {
            Space::Camera => Some(0),
            Space::Object => Some(2),
            Space::World => None,
        };
        let mut v = v;
        if let Some(b) = base(from) {
            // space → world: the inverse matrix, and for normals the forward one.
            v = self.apply(k, b + 1, b, &v);
        }
        if let Some(b) = base(to) {
            v = self.apply(k, b, b + 1, &v);
        }
        v
    }

    // ---- results ----

    fn store_prelude(&mut self) -> R<()> {
        let p = self.p;
        let dst = self.frag; // second parameter: the uniform block to write
        for &v in &p.prelude.body {
            let Some(&slot) = self.layout.prelude.get(&v.index()) else {
                continue;
            };
            let ty = self.ty(v);
            let xs = self.get(v)?;
            for (c, x) in xs.into_iter().enumerate() {
                let x = if kind(ty) == Kind::B {
                    self.b.ins().uextend(I32, x)
                } else {
                    x
                };
                self.b.ins().store(flags(), x, dst, ((slot + c) * 4) as i32);
            }
        }
        self.b.ins().return_(&[]);
        Ok(())
    }

    /// Writes the outputs through the guard to `out`; returns the guard's count (batch: per
    /// lane, as an i32x4 of 0 / −1 sums negated: lanes' counts).
    fn store_outputs(&mut self) -> R<V> {
        let p = self.p;
        let out = self.out;
        let esize = if self.batch() { 16 } else { 4 };
        let mut offset = 0usize;
        let mut bad = if self.batch() {
            self.vconst(0)
        } else {
            self.b.ins().iconst(I32, 0)
        };
        let inf = self.fconst(f32::INFINITY);
        let zero = self.fconst(0.0);
        for o in &p.outputs {
            let ty = self.ty(o.value);
            let width = ty.width().max(1);
            let mut xs: Vec<V> = Vec::new();
            match kind(ty) {
                Kind::B => {
                    let x = self.get(o.value)?[0];
                    xs.push(self.convert(Type::Bool, Type::Float, x));
                }
                Kind::I => {
                    let x = self.get(o.value)?[0];
                    xs.push(self.convert(Type::Int, Type::Float, x));
                }
                Kind::F => {
                    for x in self.get(o.value)? {
                        let a = self.b.ins().fabs(x);
                        let nf = self.fcmp(FloatCC::UnorderedOrGreaterThanOrEqual, a, inf);
                        xs.push(self.sel(nf, zero, x));
                        bad = if self.batch() {
                            self.b.ins().isub(bad, nf)
                        } else {
                            let n = self.b.ins().uextend(I32, nf);
                            self.b.ins().iadd(bad, n)
                        };
                    }
                }
            }
            for (c, x) in xs.into_iter().enumerate() {
                let off = ((offset + c) * esize) as i32;
                self.b.ins().store(flags(), x, out, off);
            }
            offset += width;
        }
        Ok(bad)
    }
}

/// Byte offsets of a stream in [`Fragment`] and [`FragmentX4`], and its component count.
fn stream_field(s: Stream) -> ((i32, i32), i32) {
    macro_rules! f {
        ($field:ident, $n:expr) => {
            (
                (
                    offset_of!(Fragment, $field) as i32,
                    offset_of!(FragmentX4, $field) as i32,
                ),
                $n,
            )
        };
    }
    match s {
        Stream::P => f!(p, 3),
        Stream::N => f!(n, 3),
        Stream::Ng => f!(ng, 3),
        Stream::I => f!(i, 3),
        Stream::Uv => f!(uv, 2),
        Stream::DPdu => f!(dpdu, 3),
        Stream::DPdv => f!(dpdv, 3),
        Stream::DPdx => f!(dpdx, 3),
        Stream::DPdy => f!(dpdy, 3),
        Stream::Time => f!(time, 1),
        Stream::RayType => f!(ray_type, 1),
        Stream::RayDepth => f!(ray_depth, 1),
        Stream::Rand => f!(rand, 4),
    }
}
