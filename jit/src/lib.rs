//! shadenet-jit: the Cranelift back end (DESIGN §6).
//!
//! This crate owns the lowering of a specialized [`Program`] to CLIF ([`lower`]), the ABI
//! between compiled code and Rust ([`abi`]: the call context, entry signatures and the
//! helpers compiled code calls) and [`JitBackend`], which compiles a program into a
//! [`JitMaterial`] with up to three native functions:
//!
//! - **prelude** (`fn(ctx, uniforms)`): evaluates the prelude once per material and stores
//!   its values in the material's uniform block (after the parameter values);
//! - **scalar** (`fn(ctx, *const Fragment, *mut f32) -> u32`): one fragment, for single hits
//!   and recursive rays;
//! - **batch** (`fn(ctx, *const FragmentX4, *mut f32, n) -> u32`): `n` fragments in
//!   consecutive four-lane packets (`shadenet_runtime::packets`), one packet per turn of a
//!   loop inside the entry, with Cranelift's 128-bit vectors (`f32x4`), varying
//!   conditionals as lane masks; the environment helpers run once per call, not per packet.
//!   [`Material::shade_many`] without a scene is one call of it.
//!
//! Both shading entries write every output in the interpreter's layout through the same
//! guard (non-finite → 0, counted) and return the count. Intrinsics that need the scene
//! (light samples, ambient light, space matrices, textures, traced rays, ambient occlusion,
//! light visibility) and the transcendental, noise and colour functions are calls of
//! `extern "C"` helpers that run the interpreter's own Rust code; arithmetic is inline and
//! bit-identical to `shadenet_graph::ops` (see [`lower`]). The scalar entry sees the
//! renderer's scene through `ShadeCtx::scene`; the batch entry through `shade_many`'s scene,
//! each lane asking its own fragment's services (`SceneServices::fragment`).
//!
//! Matrices are values like vectors (9 or 16 components, row-major), constant, uniform or
//! per fragment: every op of a valid program compiles. An op this back end cannot compile
//! (today only one refused by [`JitOptions::refuse`], which tests use) makes [`JitBackend`] fall back to the interpreter for
//! that material, saying once which op and why; it never panics on a valid program.
//!
//! It must not touch: the IR, the op semantics or the optimizer (`shadenet-graph`), the
//! interpreter and the scene intrinsics (`shadenet-runtime`) — it calls them; it defines no
//! numerics of its own beyond transcribing `ops` into CLIF.

pub mod abi;
pub mod lower;

use abi::{BatchFn, CallCtx, PreludeFn, ScalarFn};
use cranelift_codegen::ir::UserFuncName;
use cranelift_codegen::isa::OwnedTargetIsa;
use cranelift_codegen::settings::{self, Configurable};
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{Linkage, Module, default_libcall_names};
use lower::{Helpers, Lowerer, Mode, UniformLayout, Unsupported};
use shadenet_graph::ir::{Program, Value};
use shadenet_graph::opt::{self, Specialization};
use shadenet_graph::types::ConstValue;
use shadenet_runtime::backend::{BatchResult, BatchTimes, CompileStats, Material, MaterialInfo};
use shadenet_runtime::interp::{OutputSlot, output_layout};
use shadenet_runtime::texture::TextureSet;
use shadenet_runtime::{
    Backend, BackendError, FragmentX4, Fragments, InterpMaterial, LANES, SceneServices, ShadeCtx,
    ShadeEnv, packed_len,
};
use std::fmt::Write as _;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

/// Cranelift's optimization level for a compile.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OptLevel {
    /// `none` when the specialization switches CSE off (then no value numbering happens
    /// anywhere, Cranelift's e-graph included, so each IR op stays one machine op — what the
    /// per-node benchmark measures), `speed` otherwise.
    Auto,
    /// No Cranelift mid-end optimization (instruction selection and register allocation
    /// still run).
    None,
    /// Cranelift's e-graph optimizations (GVN, constant folding, LICM, alias analysis).
    Speed,
}

/// What [`JitBackend`] compiles and how.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct JitOptions {
    /// Compile the scalar entry (without it, [`Material::shade`] runs the batch entry on a
    /// one-fragment packet).
    pub scalar: bool,
    /// Compile the batch entry (without it, [`Material::shade_x4`] runs the scalar entry per
    /// lane). With the scalar entry as well, the batch entry is compiled when a batch call
    /// first needs it (most renders call only the scalar entry; its compile time is then not
    /// in the material's [`CompileStats`]); `emit_clif` compiles both at once.
    pub batch: bool,
    /// Cranelift's optimization level.
    pub opt: OptLevel,
    /// On an op the JIT cannot compile, return the interpreter for that material (true) or
    /// the error (false).
    pub fallback: bool,
    /// Print one line on standard error when falling back.
    pub log_fallback: bool,
    /// Ops (by their short name, as `Op::short_name` gives it: `select`, `construct`…) to
    /// treat as not supported: the fallback path for every valid program is otherwise
    /// unreachable (the JIT compiles every op), so tests use this to exercise it. Empty by
    /// default.
    pub refuse: Vec<String>,
}

impl Default for JitOptions {
    fn default() -> Self {
        JitOptions {
            scalar: true,
            batch: true,
            opt: OptLevel::Auto,
            fallback: true,
            log_fallback: true,
            refuse: Vec::new(),
        }
    }
}

/// The Cranelift back end.
#[derive(Clone, Debug, Default)]
pub struct JitBackend {
    /// Options.
    pub options: JitOptions,
}

impl JitBackend {
    /// A back end with default options.
    pub fn new() -> JitBackend {
        JitBackend::default()
    }

    /// A back end with these options.
    pub fn with_options(options: JitOptions) -> JitBackend {
        JitBackend { options }
    }

    fn build(
        &self,
        program: &Program,
        optimize: Duration,
        speed: bool,
    ) -> Result<Arc<dyn Material>, BackendError> {
        let fail = |what: String| -> Result<Arc<dyn Material>, BackendError> {
            if !self.options.fallback {
                return Err(BackendError::Codegen {
                    backend: "jit",
                    material: program.name.clone(),
                    message: what,
                });
            }
            if self.options.log_fallback {
                eprintln!("shadenet-jit: {what}; falling back to the interpreter");
            }
            Ok(Arc::new(
                InterpMaterial::new(program, optimize)?.as_fallback(what),
            ))
        };
        match compile(program, &self.options, optimize, speed, false) {
            Ok((m, _)) => Ok(Arc::new(m)),
            Err(Fail::Texture(e)) => Err(e.into()),
            Err(Fail::Unsupported(u)) => {
                if !self.options.fallback {
                    return Err(BackendError::Unsupported {
                        backend: "jit",
                        material: program.name.clone(),
                        op: u.op,
                        reason: u.reason,
                    });
                }
                fail(format!(
                    "material `{}`: {} is not supported: {}",
                    program.name, u.op, u.reason
                ))
            }
            Err(Fail::Codegen(msg)) => fail(format!(
                "material `{}`: code generation failed: {msg}",
                program.name
            )),
        }
    }
}

impl Backend for JitBackend {
    fn name(&self) -> &'static str {
        "jit"
    }

    fn compile_program(
        &self,
        program: &Program,
        optimize: Duration,
    ) -> Result<Arc<dyn Material>, BackendError> {
        self.build(program, optimize, self.options.opt != OptLevel::None)
    }

    fn compile(
        &self,
        program: &Program,
        spec: &Specialization,
    ) -> Result<Arc<dyn Material>, BackendError> {
        let t = Instant::now();
        let (optimized, _) = opt::run(program, spec);
        let speed = match self.options.opt {
            OptLevel::Auto => spec.passes.cse,
            OptLevel::None => false,
            OptLevel::Speed => true,
        };
        self.build(&optimized, t.elapsed(), speed)
    }
}

/// The CLIF text of every function compiled for `program` (prelude, scalar, batch), as
/// Cranelift receives it (before its own optimizations). `speed` selects Cranelift's
/// optimization level (it does not change the input CLIF).
pub fn emit_clif(
    program: &Program,
    options: &JitOptions,
    speed: bool,
) -> Result<String, BackendError> {
    match compile(program, options, Duration::ZERO, speed, true) {
        Ok((_, text)) => Ok(text),
        Err(Fail::Texture(e)) => Err(e.into()),
        Err(Fail::Unsupported(u)) => Err(BackendError::Unsupported {
            backend: "jit",
            material: program.name.clone(),
            op: u.op,
            reason: u.reason,
        }),
        Err(Fail::Codegen(message)) => Err(BackendError::Codegen {
            backend: "jit",
            material: program.name.clone(),
            message,
        }),
    }
}

enum Fail {
    Texture(shadenet_runtime::TextureError),
    Unsupported(Unsupported),
    Codegen(String),
}

/// The host ISA at one optimization level, built once per process.
fn isa(speed: bool) -> Result<OwnedTargetIsa, String> {
    static ISAS: [OnceLock<Result<OwnedTargetIsa, String>>; 2] = [OnceLock::new(), OnceLock::new()];
    ISAS[speed as usize]
        .get_or_init(|| {
            let mut fb = settings::builder();
            let set = |fb: &mut settings::Builder, k: &str, v: &str| {
                fb.set(k, v)
                    .map_err(|e| format!("cranelift setting {k}: {e}"))
            };
            set(&mut fb, "opt_level", if speed { "speed" } else { "none" })?;
            set(&mut fb, "is_pic", "false")?;
            set(&mut fb, "use_colocated_libcalls", "false")?;
            set(
                &mut fb,
                "enable_verifier",
                if cfg!(debug_assertions) {
                    "true"
                } else {
                    "false"
                },
            )?;
            let builder = cranelift_native::builder()
                .map_err(|e| format!("this host is not supported by Cranelift: {e}"))?;
            builder
                .finish(settings::Flags::new(fb))
                .map_err(|e| format!("cannot build the host ISA: {e}"))
        })
        .clone()
}

/// A JIT module kept alive for its code and freed with the material.
struct Code(Option<JITModule>);

// SAFETY: after `finalize_definitions` the module is never used again except to free its
// memory in `Drop`, which takes `&mut self`; the code it owns is immutable and safe to run
// from any thread.
unsafe impl Send for Code {}
// SAFETY: as above: no `&self` method of `Code` touches the module.
unsafe impl Sync for Code {}

impl Drop for Code {
    fn drop(&mut self) {
        if let Some(m) = self.0.take() {
            // SAFETY: the material owning this code is being dropped: no thread can call
            // its functions any more.
            unsafe { m.free_memory() };
        }
    }
}

/// A program compiled by [`JitBackend`].
pub struct JitMaterial {
    scalar: Option<ScalarFn>,
    batch: Option<BatchFn>,
    /// The batch entry, compiled when first needed (with both entries asked for).
    lazy_batch: Option<LazyBatch>,
    uniforms: Box<[u32]>,
    textures: Box<TextureSet>,
    /// What the print ops write (the message helpers read it through `CallCtx::prints`).
    prints: Box<abi::PrintTable>,
    layout: Vec<OutputSlot>,
    width: usize,
    info: MaterialInfo,
    /// Loop executions stopped at the iteration limit, all calls and threads.
    loop_limits: AtomicU64,
    // Last: dropped after everything that points into it.
    _code: Code,
}

impl JitMaterial {
    /// The batch entry: compiled with the material, or on first use.
    fn batch(&self) -> Option<BatchFn> {
        self.batch.or_else(|| self.lazy_batch.as_ref()?.get())
    }

    /// Puts the messages a batch entry call wrote in fragment order (see `abi/print.rs`).
    fn flush_messages(&self) {
        if !self.prints.is_empty() {
            shadenet_runtime::messages::flush_batch();
        }
    }

    /// Adds one call's loop stops (`CallCtx::loop_limits`) to the material's total.
    fn count(&self, loop_limits: u32) {
        if loop_limits > 0 {
            let n = u64::from(loop_limits);
            self.loop_limits.fetch_add(n, Ordering::Relaxed);
        }
    }

    /// The call context; `scene` is the shading context's `scene` field (scalar calls), a
    /// batch's services (`shade_many` with a scene: set `batch_scene` and the lane memos
    /// after) or `None` (no scene).
    fn call_ctx(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&Option<&dyn SceneServices>>,
        visibility: Option<&abi::VisibilityMemo>,
    ) -> CallCtx {
        CallCtx {
            visibility: visibility.map_or(std::ptr::null(), |m| m as *const _),
            visibility_x4: std::ptr::null(),
            first: 0,
            lanes: LANES as u32,
            batch_scene: 0,
            loop_limits: 0,
            prints: &*self.prints,
            env,
            textures: &*self.textures,
            uniforms: self.uniforms.as_ptr(),
            mask,
            n_lights: abi::light_samples(env),
            scene: scene.map_or(std::ptr::null(), |s| {
                (s as *const Option<&dyn SceneServices>).cast::<abi::SceneRef>()
            }),
        }
    }
}

impl Material for JitMaterial {
    fn layout(&self) -> &[OutputSlot] {
        &self.layout
    }

    fn width(&self) -> usize {
        self.width
    }

    fn shade(&self, ctx: &ShadeCtx, out: &mut [f32]) -> u32 {
        assert!(out.len() >= self.width, "output buffer too small");
        let memo = abi::VisibilityMemo::default();
        let memos: [abi::VisibilityMemo; LANES] = Default::default();
        let mut cc = self.call_ctx(ctx.env, ctx.mask, Some(&ctx.scene), Some(&memo));
        cc.visibility_x4 = &memos;
        let bad = match (self.scalar, self.batch()) {
            // SAFETY: the function was compiled for this material's layout; `out` holds
            // `width` floats; the context's pointers live for the call.
            (Some(f), _) => unsafe { f(&mut cc, &ctx.frag, out.as_mut_ptr()) },
            (None, Some(f)) => {
                let packet = FragmentX4::gather(std::slice::from_ref(&ctx.frag));
                let mut soa = vec![0.0f32; self.width * LANES];
                // SAFETY: as above, with `width * 4` floats.
                let bad = unsafe { f(&mut cc, &packet, soa.as_mut_ptr(), 1) };
                self.flush_messages();
                for (k, o) in out[..self.width].iter_mut().enumerate() {
                    *o = soa[k * LANES];
                }
                bad
            }
            (None, None) => 0,
        };
        self.count(cc.loop_limits);
        bad
    }

    fn shade_x4(
        &self,
        env: &ShadeEnv,
        mask: u32,
        frags: &FragmentX4,
        active: usize,
        out: &mut [f32],
    ) -> u32 {
        assert!(out.len() >= self.width * LANES, "output buffer too small");
        let mut cc = self.call_ctx(env, mask, None, None);
        match (self.batch(), self.scalar) {
            (Some(f), _) => {
                // SAFETY: the function was compiled for this material's layout; `out` holds
                // `width * 4` floats; the context's pointers live for the call.
                let bad = unsafe { f(&mut cc, frags, out.as_mut_ptr(), active.min(LANES) as u32) };
                self.flush_messages();
                self.count(cc.loop_limits);
                bad
            }
            (None, Some(f)) => {
                let mut one = vec![0.0f32; self.width];
                let mut bad = 0;
                for lane in 0..LANES {
                    let frag = frags.lane(lane);
                    cc.loop_limits = 0;
                    // SAFETY: as above, with `width` floats.
                    let b = unsafe { f(&mut cc, &frag, one.as_mut_ptr()) };
                    // Padding lanes count nothing, as for the guard.
                    if lane < active {
                        bad += b;
                        self.count(cc.loop_limits);
                    }
                    for (k, x) in one.iter().enumerate() {
                        out[k * LANES + lane] = *x;
                    }
                }
                bad
            }
            (None, None) => 0,
        }
    }

    fn info(&self) -> &MaterialInfo {
        &self.info
    }

    fn loop_limits(&self) -> u64 {
        self.loop_limits.load(Ordering::Relaxed)
    }

    fn shade_many(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &Fragments,
        out: &mut [f32],
    ) -> BatchResult {
        let t = std::time::Instant::now();
        let nonfinite = match (scene, self.batch()) {
            (_, Some(f)) if !frags.is_empty() => {
                assert!(
                    out.len() >= packed_len(self.width, frags.len()),
                    "output buffer too small"
                );
                // The batch's services: lane `l` of the packet at `first` asks
                // `fragment_services(scene, first + l)`, through its own memo.
                let services: Option<&dyn SceneServices> = scene;
                let memos: [abi::VisibilityMemo; LANES] = Default::default();
                let mut cc = self.call_ctx(env, mask, Some(&services), None);
                cc.batch_scene = 1;
                cc.visibility_x4 = &memos;
                // Calls of at most 2³⁰ fragments (the entry counts them in an i32).
                const CALL: usize = 1 << 28;
                let stride = self.width * LANES;
                let mut bad = 0u64;
                for (c, packets) in frags.packets().chunks(CALL).enumerate() {
                    let n = (frags.len() - c * CALL * LANES).min(CALL * LANES);
                    let dst = &mut out[c * CALL * stride..];
                    cc.first = (c * CALL * LANES) as u32;
                    // SAFETY: the function was compiled for this material's layout; `packets`
                    // and `dst` hold the `n` fragments' whole packets (asserted above); the
                    // context (written by the compiled loop: `first`, `lanes`) and what it
                    // points to live for the call.
                    bad +=
                        unsafe { f(&mut cc, packets.as_ptr(), dst.as_mut_ptr(), n as u32) } as u64;
                    self.flush_messages();
                    self.count(cc.loop_limits);
                    cc.loop_limits = 0;
                }
                bad
            }
            (None, _) => shadenet_runtime::shade_packets(self, env, mask, frags, out),
            (Some(scene), _) => shadenet_runtime::shade_each(self, env, mask, scene, frags, out),
        };
        BatchResult {
            nonfinite,
            times: BatchTimes {
                kernels: t.elapsed(),
                ..BatchTimes::default()
            },
        }
    }
}

/// A parameter's default as uniform slots (floats rounded to f32, as the interpreter does).
fn const_bits(c: &ConstValue) -> Vec<u32> {
    let f = |x: &f64| (*x as f32).to_bits();
    match c {
        ConstValue::Bool(b) => vec![*b as u32],
        ConstValue::Int(i) => vec![*i as u32],
        ConstValue::String(_) => vec![0],
        ConstValue::Float(x) => vec![f(x)],
        ConstValue::Vec2(v) => v.iter().map(f).collect(),
        ConstValue::Vec3(v) | ConstValue::Color(v) => v.iter().map(f).collect(),
        ConstValue::Vec4(v) | ConstValue::Color4(v) => v.iter().map(f).collect(),
        ConstValue::Matrix33(m) => m.iter().map(f).collect(),
        ConstValue::Matrix44(m) => m.iter().map(f).collect(),
    }
}

fn compile(
    program: &Program,
    options: &JitOptions,
    optimize: Duration,
    speed: bool,
    want_clif: bool,
) -> Result<(JitMaterial, String), Fail> {
    if let Some(v) = (0..program.exprs.len())
        .map(Value::new)
        .find(|v| options.refuse.contains(&program.op(*v).short_name()))
    {
        return Err(Fail::Unsupported(Unsupported {
            value: v,
            op: format!("{v:?} = {}", program.op(v).short_name()),
            reason: "refused by JitOptions::refuse".into(),
        }));
    }
    let textures = TextureSet::load(&program.textures).map_err(Fail::Texture)?;
    let mut stats = CompileStats {
        optimize,
        ops: program.op_count(),
        ..CompileStats::default()
    };
    // With both entries asked for, the batch entry is compiled when a batch call first needs
    // it (most renders only call the scalar entry); `--emit clif` shows both.
    let lazy = options.scalar && options.batch && !want_clif;
    let mut modes = Vec::new();
    if !program.prelude.body.is_empty() {
        modes.push(Mode::Prelude);
    }
    if options.scalar {
        modes.push(Mode::Scalar);
    }
    if options.batch && !lazy {
        modes.push(Mode::Batch);
    }
    let mut text = String::new();
    let (module, entries) = define_entries(
        program,
        &modes,
        speed,
        &mut stats,
        want_clif.then_some(&mut text),
    )?;
    let layout = UniformLayout::new(program);
    let mut uniforms = vec![0u32; layout.size].into_boxed_slice();
    for (d, &slot) in program.params.iter().zip(&layout.params) {
        for (k, bits) in const_bits(&d.default).into_iter().enumerate() {
            uniforms[slot + k] = bits;
        }
    }
    let (mut scalar, mut batch, mut prelude) = (None, None, None);
    for (mode, ptr) in entries {
        // SAFETY: each function was compiled with the signature of its mode (see
        // `lower::signature`), which these types transcribe.
        unsafe {
            match mode {
                Mode::Scalar => scalar = Some(std::mem::transmute::<*const u8, ScalarFn>(ptr)),
                Mode::Batch => batch = Some(std::mem::transmute::<*const u8, BatchFn>(ptr)),
                Mode::Prelude => prelude = Some(std::mem::transmute::<*const u8, PreludeFn>(ptr)),
            }
        }
    }
    let textures = Box::new(textures);
    if let Some(f) = prelude {
        let env = ShadeEnv::default();
        let up = uniforms.as_mut_ptr();
        let cc = CallCtx {
            env: &env,
            textures: &*textures,
            uniforms: up,
            mask: u32::MAX,
            n_lights: 0,
            scene: std::ptr::null(),
            visibility: std::ptr::null(),
            visibility_x4: std::ptr::null(),
            first: 0,
            lanes: LANES as u32,
            batch_scene: 0,
            loop_limits: 0,
            prints: std::ptr::null(),
        };
        // SAFETY: the prelude reads parameters and writes prelude slots of this block, both
        // inside it (the layout sized it); it reads neither fragment nor environment.
        unsafe { f(&cc, up) };
    }
    let (slots, width) = output_layout(program);
    Ok((
        JitMaterial {
            scalar,
            batch,
            lazy_batch: lazy.then(|| LazyBatch {
                program: program.clone(),
                speed,
                entry: OnceLock::new(),
            }),
            uniforms,
            textures,
            prints: Box::new(abi::PrintTable::new(program)),
            layout: slots,
            width,
            info: MaterialInfo {
                backend: "jit",
                fallback: None,
                stats,
            },
            loop_limits: AtomicU64::new(0),
            _code: Code(Some(module)),
        },
        text,
    ))
}

/// Each compiled entry's mode and address.
type Entries = Vec<(Mode, *const u8)>;

/// Declares, lowers and defines the entries `modes` of `program` in a fresh JIT module and
/// finalizes it: the module (which owns the code) and each entry's address. Adds the lower
/// and codegen times and sizes to `stats`; `clif` receives the Cranelift IR text.
fn define_entries(
    program: &Program,
    modes: &[Mode],
    speed: bool,
    stats: &mut CompileStats,
    mut clif: Option<&mut String>,
) -> Result<(JITModule, Entries), Fail> {
    let isa = isa(speed).map_err(Fail::Codegen)?;
    let cg = |e: cranelift_module::ModuleError| Fail::Codegen(format!("{e:?}"));
    let mut builder = JITBuilder::with_isa(isa, default_libcall_names());
    builder.symbols(Helpers::symbols());
    let mut module = JITModule::new(builder);
    let helpers = Helpers::declare(&mut module).map_err(Fail::Codegen)?;
    let layout = UniformLayout::new(program);
    if let Some(text) = clif.as_deref_mut() {
        let _ = writeln!(text, "; helper functions (u0:N = symbol):");
        for (id, decl) in module.declarations().get_functions() {
            let _ = writeln!(text, ";   u0:{} = {}", id.as_u32(), decl.linkage_name(id));
        }
    }
    let mut ids = Vec::new();
    let mut fbc = FunctionBuilderContext::new();
    let mut ctx = module.make_context();
    for &mode in modes {
        let name = match mode {
            Mode::Prelude => "prelude",
            Mode::Scalar => "scalar",
            Mode::Batch => "batch",
        };
        let t = Instant::now();
        let sig = lower::signature(&module, mode);
        let id = module
            .declare_function(name, Linkage::Local, &sig)
            .map_err(cg)?;
        ctx.func.signature = sig;
        ctx.func.name = UserFuncName::user(0, id.as_u32());
        {
            let fb = FunctionBuilder::new(&mut ctx.func, &mut fbc);
            Lowerer::new(program, mode, fb, &mut module, &helpers, &layout)
                .finish()
                .map_err(Fail::Unsupported)?;
        }
        stats.lower += t.elapsed();
        let f = &ctx.func;
        stats.ir_insts += f
            .layout
            .blocks()
            .map(|b| f.layout.block_insts(b).count())
            .sum::<usize>();
        if let Some(text) = clif.as_deref_mut() {
            let _ = writeln!(text, "; {name} entry of material `{}`", program.name);
            let _ = writeln!(text, "{}", ctx.func.display());
        }
        let t = Instant::now();
        module.define_function(id, &mut ctx).map_err(cg)?;
        stats.codegen += t.elapsed();
        stats.code_bytes += ctx.compiled_code().map_or(0, |c| c.code_buffer().len());
        module.clear_context(&mut ctx);
        ids.push((mode, id));
    }
    let t = Instant::now();
    module.finalize_definitions().map_err(cg)?;
    stats.link = t.elapsed();
    let entries = ids
        .into_iter()
        .map(|(mode, id)| (mode, module.get_finalized_function(id)))
        .collect();
    Ok((module, entries))
}

/// A batch entry compiled on first use: the program it is compiled from and, once it has
/// been, the entry with the module that owns its code (`None`: it could not be compiled,
/// and batch calls run the scalar entry per lane).
struct LazyBatch {
    program: Program,
    speed: bool,
    entry: OnceLock<Option<(BatchFn, Code)>>,
}

impl LazyBatch {
    /// The batch entry, compiling it the first time.
    fn get(&self) -> Option<BatchFn> {
        self.entry
            .get_or_init(|| {
                let mut stats = CompileStats::default();
                let (module, entries) =
                    define_entries(&self.program, &[Mode::Batch], self.speed, &mut stats, None)
                        .ok()?;
                let ptr = entries.first()?.1;
                // SAFETY: compiled with the batch mode's signature, which `BatchFn`
                // transcribes; the module owning the code lives beside the pointer.
                let f = unsafe { std::mem::transmute::<*const u8, BatchFn>(ptr) };
                Some((f, Code(Some(module))))
            })
            .as_ref()
            .map(|(f, _)| *f)
    }
}
