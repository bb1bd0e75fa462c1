//! Back ends (DESIGN §6): the [`Backend`] and [`Material`] traits every back end implements,
//! the interpreter back end ([`InterpBackend`]), 4-wide structure-of-arrays fragment packets
//! ([`FragmentX4`]) and the material cache ([`MaterialCache`]).
//!
//! A back end turns a program into a [`Material`]: something that shades one fragment
//! ([`Material::shade`]) or a packet of four ([`Material::shade_x4`]) and writes every
//! program output, flattened to floats in the layout [`Material::layout`] gives (the
//! interpreter's [`OutputSlot`]s), through the output guard (a non-finite float becomes 0 and
//! is counted). Materials are `Send + Sync`: one compiled material is called from every
//! rayon thread at once, with no shared mutable state on the hot path.
//!
//! [`Backend::compile`] takes the *linked, unoptimized* program and the [`Specialization`]
//! and runs the optimizer ([`opt::run`]) itself, so that a compiled material is a function of
//! `(program, specialization)` — the [`MaterialCache`] key. A caller that has already
//! optimized (or wants no optimization at all, as the parity tests do) calls
//! [`Backend::compile_program`] with the program to run as it is.

use crate::ctx::{Fragment, SceneServices, ShadeCtx, ShadeEnv};
use crate::interp::{Interpreter, OutputSlot, Scratch, ShadeOut};
use crate::packets::{FragmentX4, Fragments, LANES, packed_len, unpacked};
use crate::texture::TextureError;
use shadenet_graph::ir::Program;
use shadenet_graph::opt::{self, Specialization};
use std::cell::RefCell;
use std::collections::HashMap;
use std::fmt;
use std::hash::{Hash, Hasher};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Where the time of one compile went, and how big the result is (zero where a back end has
/// no such phase: the interpreter neither lowers nor generates code).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CompileStats {
    /// Specialization and optimization ([`opt::run`]).
    pub optimize: Duration,
    /// Lowering the IR to the back end's own IR (CLIF for the JIT).
    pub lower: Duration,
    /// Code generation (Cranelift: optimization, instruction selection, register
    /// allocation, emission).
    pub codegen: Duration,
    /// Linking: resolving symbols and making the code executable.
    pub link: Duration,
    /// Machine code size in bytes, all entry points together.
    pub code_bytes: usize,
    /// Instructions of the back end's IR (CLIF), all entry points together.
    pub ir_insts: usize,
    /// Ops of the program compiled.
    pub ops: usize,
}

impl CompileStats {
    /// Total preprocessing time after linking the network: optimize + lower + codegen + link.
    pub fn total(&self) -> Duration {
        self.optimize + self.lower + self.codegen + self.link
    }
}

impl fmt::Display for CompileStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        write!(
            f,
            "{} ops; optimize {:.3} ms, lower {:.3} ms, codegen {:.3} ms, link {:.3} ms \
             (total {:.3} ms); {} IR instructions, {} bytes of code",
            self.ops,
            ms(self.optimize),
            ms(self.lower),
            ms(self.codegen),
            ms(self.link),
            ms(self.total()),
            self.ir_insts,
            self.code_bytes
        )
    }
}

/// What a compiled material is and how it was made.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialInfo {
    /// The back end that runs it (`interp`, `jit`, …).
    pub backend: &'static str,
    /// Set when the requested back end could not compile the program and this material is
    /// the interpreter standing in for it: which op and why.
    pub fallback: Option<String>,
    /// Compile statistics.
    pub stats: CompileStats,
}

/// A compiled material: shades fragments and writes every program output, guarded.
pub trait Material: Send + Sync {
    /// Where each output's floats are in a fragment's output (the interpreter's layout).
    fn layout(&self) -> &[OutputSlot];

    /// Floats per fragment in an output (sum of the slots' widths).
    fn width(&self) -> usize;

    /// Shades one fragment into `out[..width()]`; returns how many non-finite floats the
    /// guard replaced with 0. `out` must hold at least [`Material::width`] floats.
    fn shade(&self, ctx: &ShadeCtx, out: &mut [f32]) -> u32;

    /// Shades the first `active` (1..=4) lanes of a packet, every lane with the same
    /// environment and component mask. `out` holds `width() * 4` floats, structure of
    /// arrays: float `k` of lane `l` is `out[k * 4 + l]` (inactive lanes get values too,
    /// computed from the padding fragment). Returns the non-finite floats replaced in the
    /// active lanes.
    fn shade_x4(
        &self,
        env: &ShadeEnv,
        mask: u32,
        frags: &FragmentX4,
        active: usize,
        out: &mut [f32],
    ) -> u32;

    /// Which back end runs it, whether it is a fallback, and compile statistics.
    fn info(&self) -> &MaterialInfo;

    /// Loop executions of this material, over all its calls and threads so far, that
    /// stopped at [`LOOP_ITERATION_LIMIT`](shadenet_graph::ir::LOOP_ITERATION_LIMIT) with
    /// their condition still true (a shader bug that would otherwise hang the render). A
    /// back end that cannot count returns 0; one whose programs have no loop too.
    fn loop_limits(&self) -> u64 {
        0
    }

    /// Shades any number of fragments, every one with the same environment, component mask
    /// and scene. `out` receives the outputs in the packets' layout
    /// ([`crate::packets::packed_index`]: per packet of four fragments, output float `k` of
    /// its four lanes as four consecutive floats) and holds at least
    /// [`packed_len`]`(width(), frags.len())` floats; guarded. This is the entry a batch back
    /// end implements (the JIT: one call of its batch entry for every packet; the GPU: one
    /// dispatch); the default shades packet by packet through [`Material::shade_x4`] without
    /// a scene, and one fragment at a time through [`Material::shade`] with one (fragment `i`
    /// with [`SceneServices::fragment`]`(i)` where the scene gives per-fragment services).
    fn shade_many(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &Fragments,
        out: &mut [f32],
    ) -> BatchResult {
        let t = Instant::now();
        let nonfinite = match scene {
            None => shade_packets(self, env, mask, frags, out),
            Some(scene) => shade_each(self, env, mask, scene, frags, out),
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

/// Shades `frags` one at a time through [`Material::shade`] with the scene (fragment `i`
/// with its own services), writing the packets' layout. Returns the non-finite floats
/// replaced.
pub fn shade_each<M: Material + ?Sized>(
    material: &M,
    env: &ShadeEnv,
    mask: u32,
    scene: &dyn SceneServices,
    frags: &Fragments,
    out: &mut [f32],
) -> u64 {
    let w = material.width();
    let mut one = vec![0.0f32; w];
    let mut bad = 0u64;
    for i in 0..frags.len() {
        let ctx = ShadeCtx {
            frag: frags.get(i),
            env,
            mask,
            scene: crate::ctx::fragment_services(Some(scene), i),
        };
        bad += material.shade(&ctx, &mut one) as u64;
        let (packet, lane) = (i / LANES, i % LANES);
        for (k, x) in one.iter().enumerate() {
            out[packet * w * LANES + k * LANES + lane] = *x;
        }
    }
    bad
}

/// Where the time of one [`Material::shade_many`] call went. A CPU back end has only
/// `kernels` (its shading time); the GPU splits upload, kernels, host steps and readback.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BatchTimes {
    /// Copying fragments and per-call data (uniforms, light samples) to the device.
    pub upload: Duration,
    /// Running the shading code (GPU: from submission to completion of the passes).
    pub kernels: Duration,
    /// Host steps between GPU passes: light samples with their shadow rays, traced rays,
    /// occlusion.
    pub host: Duration,
    /// Copying results back from the device, and the output guard.
    pub readback: Duration,
    /// GPU passes dispatched (0 on the CPU).
    pub passes: u32,
}

impl BatchTimes {
    /// The sum of the four phases.
    pub fn total(&self) -> Duration {
        self.upload + self.kernels + self.host + self.readback
    }

    /// Adds another call's times to these.
    pub fn add(&mut self, o: &BatchTimes) {
        self.upload += o.upload;
        self.kernels += o.kernels;
        self.host += o.host;
        self.readback += o.readback;
        self.passes += o.passes;
    }
}

/// The result of [`Material::shade_many`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BatchResult {
    /// Non-finite floats the output guard replaced with 0.
    pub nonfinite: u64,
    /// Where the time went.
    pub times: BatchTimes,
}

/// Shades a slice of fragments packet by packet through [`Material::shade_x4`] without a
/// scene, writing `width()` floats per fragment, fragment after fragment, into `out`: a
/// convenience for callers that hold fragments one by one (it packs and unpacks; a hot
/// path holds [`Fragments`] and calls [`Material::shade_many`]). Returns the non-finite
/// floats replaced.
pub fn shade_batch(
    material: &dyn Material,
    env: &ShadeEnv,
    mask: u32,
    frags: &[Fragment],
    out: &mut [f32],
) -> u64 {
    through_packets(material.width(), frags, out, |packed, o| {
        shade_packets(material, env, mask, packed, o)
    })
}

/// [`Material::shade_many`] for a slice of fragments, its outputs written fragment after
/// fragment (`width()` floats each) into `out`: the same convenience as [`shade_batch`]
/// (packing and unpacking) for the batch entry a back end implements, with a scene.
pub fn shade_many_unpacked(
    material: &dyn Material,
    env: &ShadeEnv,
    mask: u32,
    scene: Option<&dyn SceneServices>,
    frags: &[Fragment],
    out: &mut [f32],
) -> BatchResult {
    through_packets(material.width(), frags, out, |packed, o| {
        material.shade_many(env, mask, scene, packed, o)
    })
}

/// Packs `frags`, lets `shade` write the packets' layout, and unpacks its `w` floats per
/// fragment into `out`, fragment after fragment.
fn through_packets<R>(
    w: usize,
    frags: &[Fragment],
    out: &mut [f32],
    shade: impl FnOnce(&Fragments, &mut [f32]) -> R,
) -> R {
    let packed = Fragments::from_slice(frags);
    let mut o = vec![0.0f32; packed_len(w, frags.len())];
    let r = shade(&packed, &mut o);
    out[..w * frags.len()].copy_from_slice(&unpacked(w, frags.len(), &o));
    r
}

/// Shades any number of fragments through [`Material::shade_x4`], packet by packet, without
/// a scene: `out` (at least [`packed_len`]`(width(), frags.len())` floats) receives the
/// packets' layout. Returns the non-finite floats replaced.
pub fn shade_packets<M: Material + ?Sized>(
    material: &M,
    env: &ShadeEnv,
    mask: u32,
    frags: &Fragments,
    out: &mut [f32],
) -> u64 {
    let w = material.width();
    assert!(
        out.len() >= packed_len(w, frags.len()),
        "output buffer too small"
    );
    let mut bad = 0u64;
    let mut left = frags.len();
    for (packet, dst) in frags
        .packets()
        .iter()
        .zip(out.chunks_mut((w * LANES).max(1)))
    {
        bad += material.shade_x4(env, mask, packet, left.min(LANES), dst) as u64;
        left = left.saturating_sub(LANES);
    }
    bad
}

/// Why a back end could not compile a program.
#[derive(Debug, thiserror::Error)]
pub enum BackendError {
    /// A texture the program reads could not be loaded.
    #[error(transparent)]
    Texture(#[from] TextureError),
    /// The back end does not implement an op the program uses (a JIT falls back to the
    /// interpreter on this error).
    #[error("material `{material}`: {op} is not supported by the {backend} back end: {reason}")]
    Unsupported {
        /// The back end.
        backend: &'static str,
        /// The material.
        material: String,
        /// The op, as the IR text writes it, with its value number.
        op: String,
        /// Why.
        reason: String,
    },
    /// Code generation failed (a back-end bug: the message names the material and phase).
    #[error("material `{material}`: {backend} code generation failed: {message}")]
    Codegen {
        /// The back end.
        backend: &'static str,
        /// The material.
        material: String,
        /// What went wrong.
        message: String,
    },
}

/// A back end: compiles programs into [`Material`]s.
pub trait Backend: Send + Sync {
    /// The back end's name (`interp`, `jit`, `jit-batch`, …).
    fn name(&self) -> &'static str;

    /// Compiles `program` as it is (already specialized and optimized, or deliberately not);
    /// `optimize` is the time already spent optimizing it, recorded in the statistics.
    fn compile_program(
        &self,
        program: &Program,
        optimize: Duration,
    ) -> Result<Arc<dyn Material>, BackendError>;

    /// Specializes and optimizes a linked program for `spec` ([`opt::run`]), then compiles
    /// it.
    fn compile(
        &self,
        program: &Program,
        spec: &Specialization,
    ) -> Result<Arc<dyn Material>, BackendError> {
        let t = Instant::now();
        let (optimized, _report) = opt::run(program, spec);
        self.compile_program(&optimized, t.elapsed())
    }
}

/// The interpreter as a back end: runs any valid program, in f32.
#[derive(Clone, Copy, Debug, Default)]
pub struct InterpBackend;

impl Backend for InterpBackend {
    fn name(&self) -> &'static str {
        "interp"
    }

    fn compile_program(
        &self,
        program: &Program,
        optimize: Duration,
    ) -> Result<Arc<dyn Material>, BackendError> {
        Ok(Arc::new(InterpMaterial::new(program, optimize)?))
    }
}

/// A program run by the f32 interpreter, as a [`Material`].
#[derive(Debug)]
pub struct InterpMaterial {
    interp: Interpreter<f32>,
    width: usize,
    info: MaterialInfo,
    /// Loop executions stopped at the iteration limit, all calls and threads.
    loop_limits: AtomicU64,
}

type InterpState = (Scratch<f32>, ShadeOut<f32>);

thread_local! {
    /// Per-thread interpreter registers, reused across calls.
    static SCRATCH: RefCell<InterpState> = RefCell::new((
        Scratch::default(),
        ShadeOut::default(),
    ));
}

impl InterpMaterial {
    /// Prepares `program` for the interpreter (loads its textures).
    pub fn new(program: &Program, optimize: Duration) -> Result<InterpMaterial, TextureError> {
        let interp = Interpreter::<f32>::new(program)?;
        let width = interp.slots().iter().map(|s| s.ty.width().max(1)).sum();
        Ok(InterpMaterial {
            interp,
            width,
            info: MaterialInfo {
                backend: "interp",
                fallback: None,
                stats: CompileStats {
                    optimize,
                    ops: program.op_count(),
                    ..CompileStats::default()
                },
            },
            loop_limits: AtomicU64::new(0),
        })
    }

    /// Adds one call's loop stops to the material's total.
    fn count(&self, o: &ShadeOut<f32>) {
        if o.loop_limits > 0 {
            let n = u64::from(o.loop_limits);
            self.loop_limits.fetch_add(n, Ordering::Relaxed);
        }
    }

    /// The same material, marked as standing in for another back end that could not
    /// compile the program (`why` says which op and why).
    pub fn as_fallback(mut self, why: String) -> InterpMaterial {
        self.info.fallback = Some(why);
        self
    }

    fn with_state<R>(&self, f: impl FnOnce(&mut InterpState) -> R) -> R {
        SCRATCH.with(|s| match s.try_borrow_mut() {
            Ok(mut state) => f(&mut state),
            // Re-entered (a shader shading from inside a shader): use fresh registers.
            Err(_) => f(&mut (Scratch::default(), ShadeOut::default())),
        })
    }
}

impl Material for InterpMaterial {
    fn layout(&self) -> &[OutputSlot] {
        self.interp.slots()
    }

    fn width(&self) -> usize {
        self.width
    }

    fn shade(&self, ctx: &ShadeCtx, out: &mut [f32]) -> u32 {
        self.with_state(|(scratch, o)| {
            self.interp.shade_with(ctx, scratch, o);
            self.count(o);
            out[..self.width].copy_from_slice(&o.values);
            o.nonfinite
        })
    }

    fn shade_x4(
        &self,
        env: &ShadeEnv,
        mask: u32,
        frags: &FragmentX4,
        active: usize,
        out: &mut [f32],
    ) -> u32 {
        self.with_state(|(scratch, o)| {
            let mut bad = 0;
            for lane in 0..LANES {
                let ctx = ShadeCtx {
                    frag: frags.lane(lane),
                    env,
                    mask,
                    scene: None,
                };
                if lane < active {
                    self.interp.shade_with(&ctx, scratch, o);
                } else {
                    crate::messages::muted(|| self.interp.shade_with(&ctx, scratch, o));
                }
                for (k, v) in o.values.iter().enumerate() {
                    out[k * LANES + lane] = *v;
                }
                if lane < active {
                    bad += o.nonfinite;
                    self.count(o);
                }
            }
            bad
        })
    }

    fn info(&self) -> &MaterialInfo {
        &self.info
    }

    fn loop_limits(&self) -> u64 {
        self.loop_limits.load(Ordering::Relaxed)
    }
}

/// Compiled materials by `(back end, program, specialization)`: a material is compiled once
/// and shared (`Arc`) by every caller after that.
///
/// The program part of the key is a 64-bit hash of its IR text form (which prints every
/// op, output, parameter, component and texture); the text itself is kept and compared on a
/// hit, so a hash collision compiles again instead of returning the wrong material.
#[derive(Default)]
pub struct MaterialCache {
    entries: Mutex<HashMap<CacheKey, Vec<CacheEntry>>>,
}

type CacheKey = (&'static str, u64, Specialization);
/// A cached material with the program text it was compiled from.
type CacheEntry = (String, Arc<dyn Material>);

impl MaterialCache {
    /// An empty cache.
    pub fn new() -> MaterialCache {
        MaterialCache::default()
    }

    /// The hash of a program used as its cache key.
    pub fn program_hash(program: &Program) -> u64 {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        program.to_string().hash(&mut h);
        h.finish()
    }

    /// The material for `(backend, program, spec)`: the cached one, or a new compile
    /// (`Backend::compile`) that is then cached. Compiles run outside the lock, so two
    /// threads asking for the same new material may both compile it; one result is kept.
    pub fn get_or_compile(
        &self,
        backend: &dyn Backend,
        program: &Program,
        spec: &Specialization,
    ) -> Result<Arc<dyn Material>, BackendError> {
        let text = program.to_string();
        let mut h = std::collections::hash_map::DefaultHasher::new();
        text.hash(&mut h);
        let key = (backend.name(), h.finish(), spec.clone());
        if let Some(m) = self.lookup(&key, &text) {
            return Ok(m);
        }
        let m = backend.compile(program, spec)?;
        let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        let list = entries.entry(key).or_default();
        if let Some((_, old)) = list.iter().find(|(t, _)| *t == text) {
            return Ok(old.clone());
        }
        list.push((text, m.clone()));
        Ok(m)
    }

    fn lookup(&self, key: &CacheKey, text: &str) -> Option<Arc<dyn Material>> {
        let entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        entries
            .get(key)?
            .iter()
            .find(|(t, _)| t == text)
            .map(|(_, m)| m.clone())
    }

    /// Number of materials cached.
    pub fn len(&self) -> usize {
        let entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        entries.values().map(Vec::len).sum()
    }

    /// True when nothing is cached.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}
