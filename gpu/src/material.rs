//! [`GpuBackend`] (a `runtime::Backend`) and [`GpuMaterial`] (a `runtime::Material`).
//!
//! Owns: compiling a program for the device (its [`crate::plan`], one compute pipeline per
//! pass, the textures uploaded once, the uniform values the prelude and the parameters give,
//! the scalar companion material), and running a batch ([`Material::shade_many`]): the
//! buffers of each call, the uploads (streams and seed as structure of arrays, uniforms,
//! light samples computed on the host with rayon), the passes and host steps in order (a
//! host step reads the columns it needs back, asks each fragment's own services
//! (`SceneServices::fragment`) where its guard holds, and writes the results into
//! `sn_tmp`), the readback of `sn_out`, the output guard
//! (non-finite → 0, counted) and the time split ([`BatchTimes`]). Single fragments
//! ([`Material::shade`], [`Material::shade_x4`]) go to the companion: a dispatch per fragment
//! would cost more than the shading.
//!
//! A program the plan cannot run (or a kernel the device rejects) becomes the interpreter,
//! marked as a fallback, with one line on standard error, as the JIT does
//! ([`GpuBackend::without_fallback`] makes it an error instead). A device error while
//! shading a batch (out of memory, a lost device) shades that batch with the companion
//! instead, saying so once per material.
//!
//! Must not touch: what the kernels contain ([`crate::kernel`]) or how the program is cut
//! ([`crate::planner`]); the scene helpers it calls live in `shadenet_runtime`.

use crate::context::{GpuContext, GpuError};
pub use crate::options::{GpuOptions, PassMode};
use crate::plan::{
    self, HostKind, LIGHT_COLUMNS, Plan, Step, U_AMBIENT, U_CAMERA, U_CAMERA_INV, U_KEEP, U_MASK,
    U_N, U_OBJECT, U_OBJECT_INV, U_SAMPLES, U_VALUES, encode_const,
};
use crate::planner;
use rayon::prelude::*;
use shadenet_graph::ir::{Op, Program, Stream, Value};
use shadenet_graph::ops::Val;
use shadenet_graph::types::Type;
use shadenet_runtime::backend::{BatchResult, BatchTimes, CompileStats, FragmentX4, MaterialInfo};
use shadenet_runtime::interp::{self, Interpreter, OutputSlot};
use shadenet_runtime::texture::TextureSet;
use shadenet_runtime::{
    Backend, BackendError, Fragment, InterpMaterial, Material, SceneServices, ShadeCtx, ShadeEnv,
    lights,
};
use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt;

/// The GPU back end: compiles programs into [`GpuMaterial`]s that shade batches on the
/// device (see the module documentation).
pub struct GpuBackend {
    options: GpuOptions,
    scalar: Arc<dyn Backend>,
    ctx: Arc<GpuContext>,
    fallback: bool,
}

impl GpuBackend {
    /// A back end on the shared device ([`crate::GpuContext::shared`]); `scalar` shades the
    /// single fragments (`Material::shade`, `shade_x4`).
    pub fn new(options: GpuOptions, scalar: Arc<dyn Backend>) -> Result<GpuBackend, GpuError> {
        let ctx = crate::GpuContext::shared()?;
        Ok(GpuBackend {
            options,
            scalar,
            ctx,
            fallback: true,
        })
    }

    /// The same back end, returning the error instead of the interpreter for a program it
    /// cannot run (tests use it to be sure the device shades).
    pub fn without_fallback(mut self) -> GpuBackend {
        self.fallback = false;
        self
    }

    /// Its options.
    pub fn options(&self) -> &GpuOptions {
        &self.options
    }

    /// Compiles `program` for the device, with no fallback.
    pub fn compile_gpu(
        &self,
        program: &Program,
        optimize: Duration,
    ) -> Result<GpuMaterial, BackendError> {
        GpuMaterial::new(&self.ctx, program, &self.options, &*self.scalar, optimize)
    }
}

impl Backend for GpuBackend {
    fn name(&self) -> &'static str {
        "gpu"
    }

    fn compile_program(
        &self,
        program: &Program,
        optimize: Duration,
    ) -> Result<Arc<dyn Material>, BackendError> {
        match self.compile_gpu(program, optimize) {
            Ok(m) => Ok(Arc::new(m)),
            Err(e @ (BackendError::Unsupported { .. } | BackendError::Codegen { .. }))
                if self.fallback =>
            {
                let why = e.to_string();
                eprintln!("shadenet-gpu: {why}; falling back to the interpreter");
                Ok(Arc::new(
                    InterpMaterial::new(program, optimize)?.as_fallback(why),
                ))
            }
            Err(e) => Err(e),
        }
    }
}

/// The device objects of one pass.
struct PassGpu {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    lights: bool,
    textures: bool,
}

/// A program compiled for the GPU: its plan, one pipeline per pass, its textures on the
/// device, and the scalar companion for single fragments.
pub struct GpuMaterial {
    ctx: Arc<GpuContext>,
    program: Program,
    plan: Plan,
    /// Per step of the plan: the pass's pipeline (`None` for host steps).
    passes: Vec<Option<PassGpu>>,
    /// `sn_texels` and `sn_tex_info`, when a pass reads textures.
    textures: Option<(wgpu::Buffer, wgpu::Buffer)>,
    /// The uniform slots from [`U_VALUES`] on: prelude values and parameters.
    statics: Vec<f32>,
    companion: Arc<dyn Material>,
    layout: Vec<OutputSlot>,
    width: usize,
    info: MaterialInfo,
    /// Set once a batch failed on the device (the message is printed once).
    failed: AtomicBool,
}

impl std::fmt::Debug for GpuMaterial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuMaterial")
            .field("material", &self.program.name)
            .field("passes", &self.plan.passes())
            .field("host_steps", &self.plan.host_steps())
            .finish_non_exhaustive()
    }
}

fn gpu_err(e: impl std::fmt::Display) -> GpuError {
    GpuError::Runtime(e.to_string())
}

/// Encodes an interpreter value into buffer columns (see [`plan::encode_const`]).
fn encode_val(v: &Val<f32>, mats: &[[f32; 16]], ty: Type) -> Vec<f32> {
    let mut out = match v {
        Val::Bool(b) => vec![if *b { 1.0 } else { 0.0 }],
        Val::Int(i) => vec![f32::from_bits(*i as u32)],
        Val::Float(x) => vec![*x],
        Val::Vec2(x) => x.to_vec(),
        Val::Vec3(x) => x.to_vec(),
        Val::Mat(i) => mats.get(*i as usize).map_or(vec![0.0; 16], |m| m.to_vec()),
    };
    out.resize(crate::emit::columns(ty), 0.0);
    out
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl GpuMaterial {
    /// Plans and compiles `program` on `ctx`'s device; `scalar` compiles the companion.
    pub fn new(
        ctx: &Arc<GpuContext>,
        program: &Program,
        options: &GpuOptions,
        scalar: &dyn Backend,
        optimize: Duration,
    ) -> Result<GpuMaterial, BackendError> {
        let codegen = |message: String| BackendError::Codegen {
            backend: "gpu",
            material: program.name.clone(),
            message,
        };
        let t = Instant::now();
        let plan = planner::plan(program, options, &ctx.limits)?;
        let lower = t.elapsed();

        let textures = TextureSet::load(&program.textures)?;
        let interp = Interpreter::<f32>::with_textures(program, textures.clone());
        let mut statics = vec![0.0f32; plan.layout.uniforms - U_VALUES];
        let mut put = |slot: usize, cols: &[f32]| {
            for (k, x) in cols.iter().enumerate() {
                if let Some(d) = statics.get_mut(slot + k - U_VALUES) {
                    *d = *x;
                }
            }
        };
        for (idx, val) in interp.prelude_values() {
            if let (Some(&slot), Some(ty)) = (
                plan.layout.prelude.get(idx),
                program.exprs.get(*idx).and_then(|e| e.ty),
            ) {
                put(slot, &encode_val(val, interp.matrices(), ty));
            }
        }
        for (&i, &slot) in &plan.layout.params {
            if let Some(d) = program.params.get(i as usize) {
                put(slot, &encode_const(&d.default));
            }
        }

        // Pipelines, under error scopes: a kernel the device rejects is an error, not a
        // panic.
        let t = Instant::now();
        let device = &ctx.device;
        let scopes = [
            device.push_error_scope(wgpu::ErrorFilter::Validation),
            device.push_error_scope(wgpu::ErrorFilter::OutOfMemory),
            device.push_error_scope(wgpu::ErrorFilter::Internal),
        ];
        let mut passes = Vec::new();
        let mut pass_no = 0;
        for step in &plan.steps {
            let Step::Pass(ps) = step else {
                passes.push(None);
                continue;
            };
            let label = format!("{} pass {pass_no}", program.name);
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(&label),
                source: wgpu::ShaderSource::Wgsl(ps.wgsl.as_str().into()),
            });
            let mut entries = vec![
                storage_entry(0, true),
                storage_entry(1, true),
                storage_entry(2, false),
                storage_entry(3, false),
            ];
            if ps.lights {
                entries.push(storage_entry(4, true));
            }
            if ps.textures {
                entries.push(storage_entry(5, true));
                entries.push(storage_entry(6, true));
            }
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(&label),
                entries: &entries,
            });
            let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(&label),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&label),
                layout: Some(&pl),
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
            passes.push(Some(PassGpu {
                pipeline,
                layout,
                lights: ps.lights,
                textures: ps.textures,
            }));
            pass_no += 1;
        }
        let tex = if plan.layout.textures {
            let mut texels: Vec<[f32; 4]> = Vec::new();
            let mut info: Vec<[u32; 4]> = Vec::new();
            for i in 0..program.textures.len() {
                match textures.get(i as u32) {
                    Some(t) => {
                        info.push([texels.len() as u32, t.width, t.height, 0]);
                        texels.extend_from_slice(&t.texels);
                    }
                    None => info.push([0, 0, 0, 0]),
                }
            }
            if texels.is_empty() {
                texels.push([0.0; 4]);
            }
            if info.is_empty() {
                info.push([0; 4]);
            }
            let bytes = (texels.len() * 16) as u64;
            if bytes > plan.binding_size {
                return Err(BackendError::Unsupported {
                    backend: "gpu",
                    material: program.name.clone(),
                    op: "texture".into(),
                    reason: format!(
                        "the textures take {bytes} bytes; the adapter binds at most {}",
                        plan.binding_size
                    ),
                });
            }
            let a = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("sn_texels"),
                contents: bytemuck::cast_slice(&texels),
                usage: wgpu::BufferUsages::STORAGE,
            });
            let b = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("sn_tex_info"),
                contents: bytemuck::cast_slice(&info),
                usage: wgpu::BufferUsages::STORAGE,
            });
            Some((a, b))
        } else {
            None
        };
        let mut errors = Vec::new();
        for s in scopes.into_iter().rev() {
            if let Some(e) = pollster::block_on(s.pop()) {
                errors.push(e.to_string());
            }
        }
        if !errors.is_empty() {
            return Err(codegen(format!(
                "the device rejects the kernels: {}",
                errors.join("; ")
            )));
        }
        let codegen_time = t.elapsed();

        let companion = scalar.compile_program(program, optimize)?;
        let (layout, width) = interp::output_layout(program);
        let info = MaterialInfo {
            backend: "gpu",
            fallback: None,
            stats: CompileStats {
                optimize,
                lower,
                codegen: codegen_time,
                link: Duration::ZERO,
                code_bytes: plan.wgsl_bytes(),
                ir_insts: plan.wgsl_lines(),
                ops: program.op_count(),
            },
        };
        Ok(GpuMaterial {
            ctx: ctx.clone(),
            program: program.clone(),
            plan,
            passes,
            textures: tex,
            statics,
            companion,
            layout,
            width,
            info,
            failed: AtomicBool::new(false),
        })
    }

    /// The plan this material runs.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Whether a batch failed on the device, so that this material now shades every batch
    /// on its companion (see the module documentation).
    pub fn device_failed(&self) -> bool {
        self.failed.load(Ordering::Relaxed)
    }

    /// The scalar companion that shades single fragments.
    pub fn companion(&self) -> &Arc<dyn Material> {
        &self.companion
    }

    /// The value of a uniform bool the host can tell without the device (constants,
    /// parameters, prelude values, component queries); `None` for the others.
    fn uniform_bool(&self, v: Value, mask: u32) -> Option<bool> {
        let p = &self.program;
        if let Some(&slot) = self.plan.layout.prelude.get(&v.index()) {
            return self.statics.get(slot - U_VALUES).map(|x| *x != 0.0);
        }
        match p.op(v) {
            Op::Const(c) => encode_const(c).first().map(|x| *x != 0.0),
            Op::Param(i) => {
                let slot = *self.plan.layout.params.get(i)?;
                self.statics.get(slot - U_VALUES).map(|x| *x != 0.0)
            }
            Op::ComponentEnabled(k) => Some(mask & (1u32 << (*k as u32 & 31)) != 0),
            _ => None,
        }
    }

    /// Whether the host can tell that a guard fails for every fragment.
    fn guard_fails(&self, guard: &plan::Guard, mask: u32) -> bool {
        guard
            .iter()
            .any(|&(c, pol)| self.uniform_bool(c, mask) == Some(!pol))
    }

    /// The per-call uniforms.
    fn uniforms(&self, env: &ShadeEnv, mask: u32, n: usize, samples: usize) -> Vec<f32> {
        let mut u = vec![0.0f32; self.plan.layout.uniforms.max(U_VALUES)];
        u[U_N] = f32::from_bits(n as u32);
        u[U_MASK] = f32::from_bits(mask);
        u[U_SAMPLES] = f32::from_bits(samples as u32);
        u[U_KEEP] = f32::from_bits(0);
        let amb: [f32; 3] = lights::ambient(&env.lights);
        u[U_AMBIENT..U_AMBIENT + 3].copy_from_slice(&amb);
        for (slot, m) in [
            (U_CAMERA, &env.camera.m),
            (U_CAMERA_INV, &env.camera.inv),
            (U_OBJECT, &env.object.m),
            (U_OBJECT_INV, &env.object.inv),
        ] {
            for (k, x) in m.iter().enumerate() {
                u[slot + k] = *x as f32;
            }
        }
        u[U_VALUES..U_VALUES + self.statics.len()].copy_from_slice(&self.statics);
        u
    }

    /// The streams and seed, structure of arrays.
    fn fragment_columns(&self, frags: &[Fragment]) -> Vec<f32> {
        let n = frags.len();
        let l = &self.plan.layout;
        let mut d = vec![0.0f32; l.frag_columns * n];
        for &(s, c0) in &l.streams {
            for (i, f) in frags.iter().enumerate() {
                let vals = stream_columns(s, f);
                for (k, x) in vals.iter().enumerate() {
                    d[(c0 + k) * n + i] = *x;
                }
            }
        }
        for (i, f) in frags.iter().enumerate() {
            d[l.seed * n + i] = f32::from_bits(f.seed);
        }
        d
    }
}

/// The columns of a stream of a fragment (ints as their bits).
fn stream_columns(s: Stream, f: &Fragment) -> Vec<f32> {
    match s {
        Stream::P => f.p.to_vec(),
        Stream::N => f.n.to_vec(),
        Stream::Ng => f.ng.to_vec(),
        Stream::I => f.i.to_vec(),
        Stream::Uv => f.uv.to_vec(),
        Stream::DPdu => f.dpdu.to_vec(),
        Stream::DPdv => f.dpdv.to_vec(),
        Stream::DPdx => f.dpdx.to_vec(),
        Stream::DPdy => f.dpdy.to_vec(),
        Stream::Time => vec![f.time],
        Stream::RayType => vec![f32::from_bits(f.ray_type as u32)],
        Stream::RayDepth => vec![f32::from_bits(f.ray_depth as u32)],
    }
}

/// Values a host step reads, per fragment: its read-back columns, and what the host knows.
struct HostValues<'a> {
    m: &'a GpuMaterial,
    env: &'a ShadeEnv,
    mask: u32,
    frags: &'a [Fragment],
    /// Read-back columns (`width × n`, structure of arrays) by value.
    read: HashMap<Value, Vec<f32>>,
}

impl HostValues<'_> {
    /// The encoded columns of value `v` at fragment `i`.
    fn get(&self, v: Value, i: usize) -> Vec<f32> {
        let p = &self.m.program;
        let n = self.frags.len();
        if let Some(cols) = self.read.get(&v) {
            let w = cols.len() / n.max(1);
            return (0..w).map(|c| cols[c * n + i]).collect();
        }
        // A uniform slot's value (prelude values and parameters), as the kernels read it.
        let uniform = |slot: usize| {
            let w = crate::emit::columns(p.ty(v));
            let s = slot - U_VALUES;
            self.m
                .statics
                .get(s..s + w)
                .map_or(vec![0.0; w], |x| x.to_vec())
        };
        if let Some(&slot) = self.m.plan.layout.prelude.get(&v.index()) {
            return uniform(slot);
        }
        match p.op(v) {
            Op::Const(c) => encode_const(c),
            Op::Param(_) | Op::ComponentEnabled(_) => {
                if let Op::Param(k) = p.op(v)
                    && let Some(&slot) = self.m.plan.layout.params.get(k)
                {
                    return uniform(slot);
                }
                let b = self.m.uniform_bool(v, self.mask).unwrap_or(false);
                vec![if b { 1.0 } else { 0.0 }]
            }
            Op::Stream(s) => stream_columns(*s, &self.frags[i]),
            Op::Ambient => lights::ambient::<f32>(&self.env.lights).to_vec(),
            _ => vec![0.0; crate::emit::columns(p.ty(v))],
        }
    }

    fn vec3(&self, v: Value, i: usize) -> [f32; 3] {
        let c = self.get(v, i);
        [0, 1, 2].map(|k| c.get(k).copied().unwrap_or(0.0))
    }

    fn float(&self, v: Value, i: usize) -> f32 {
        self.get(v, i).first().copied().unwrap_or(0.0)
    }

    fn int(&self, v: Value, i: usize) -> i32 {
        self.float(v, i).to_bits() as i32
    }

    fn holds(&self, guard: &plan::Guard, i: usize) -> bool {
        guard
            .iter()
            .all(|&(c, pol)| (self.float(c, i) != 0.0) == pol)
    }
}

/// A chunk of a `shade_many` call's fragments: fragment `i` of the chunk is fragment
/// `base + i` of the call.
struct ChunkServices<'a> {
    inner: &'a dyn SceneServices,
    base: usize,
}

impl SceneServices for ChunkServices<'_> {
    fn trace(&self, origin: [f32; 3], dir: [f32; 3], ray_type: i32, depth: i32) -> [f32; 3] {
        self.inner.trace(origin, dir, ray_type, depth)
    }

    fn occluded(&self, from: [f32; 3], to: [f32; 3]) -> bool {
        self.inner.occluded(from, to)
    }

    fn occlusion(
        &self,
        p: [f32; 3],
        n: [f32; 3],
        samples: u32,
        max_distance: f32,
        seed: u32,
    ) -> f32 {
        self.inner.occlusion(p, n, samples, max_distance, seed)
    }

    fn fragment(&self, index: usize) -> Option<&dyn SceneServices> {
        self.inner.fragment(self.base + index)
    }
}

/// Light samples of every fragment as seen from `point(i)` (`None`: no samples, zeros),
/// structure of arrays: column `7 j + c` of sample `j`.
fn light_samples(
    env: &ShadeEnv,
    frags: &[Fragment],
    samples: usize,
    visible: bool,
    scene: Option<&dyn SceneServices>,
    point: &(dyn Fn(usize) -> Option<[f32; 3]> + Sync),
) -> Vec<f32> {
    let n = frags.len();
    let w = LIGHT_COLUMNS * samples;
    let mut aos = vec![0.0f32; w * n];
    aos.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(i, dst)| {
            let Some(p) = point(i) else {
                return;
            };
            let seed = frags[i].seed;
            let mut j = 0;
            for (li, light) in env.lights.iter().enumerate() {
                for k in 0..lights::sample_count(light) {
                    let Some(s) = lights::sample::<f32>(light, li as u32, k, p, seed) else {
                        continue;
                    };
                    if j >= samples {
                        return;
                    }
                    let vis = if visible && scene.is_some() {
                        interp::sample_visible(
                            shadenet_runtime::fragment_services(scene, i),
                            p,
                            s.to,
                        )
                    } else {
                        true
                    };
                    let d = &mut dst[LIGHT_COLUMNS * j..LIGHT_COLUMNS * (j + 1)];
                    d[..3].copy_from_slice(&s.l);
                    d[3..6].copy_from_slice(&s.cl);
                    d[6] = if vis { 1.0 } else { 0.0 };
                    j += 1;
                }
            }
        });
    let mut soa = vec![0.0f32; w * n];
    for i in 0..n {
        for c in 0..w {
            soa[c * n + i] = aos[i * w + c];
        }
    }
    soa
}

/// The light samples one fragment sees per shading call.
fn sample_total(env: &ShadeEnv) -> usize {
    env.lights
        .iter()
        .map(|l| lights::sample_count(l) as usize)
        .sum()
}

/// One batch's device buffers.
struct Buffers {
    uni: wgpu::Buffer,
    frag: wgpu::Buffer,
    out: wgpu::Buffer,
    tmp: wgpu::Buffer,
    light: wgpu::Buffer,
}

impl GpuMaterial {
    fn device(&self) -> &wgpu::Device {
        &self.ctx.device
    }

    fn wait(&self) -> Result<(), GpuError> {
        self.device()
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(gpu_err)
    }

    /// Copies column ranges `(first column, columns)` of `src` (columns of `n` floats) back
    /// to the host: one vector per range.
    fn read_columns(
        &self,
        src: &wgpu::Buffer,
        ranges: &[(usize, usize)],
        n: usize,
    ) -> Result<Vec<Vec<f32>>, GpuError> {
        let total: usize = ranges.iter().map(|r| r.1 * n).sum();
        if total == 0 {
            return Ok(ranges.iter().map(|_| Vec::new()).collect());
        }
        let staging = self.device().create_buffer(&wgpu::BufferDescriptor {
            label: Some("sn_readback"),
            size: (total * 4) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device().create_command_encoder(&Default::default());
        let mut at = 0u64;
        for &(c, w) in ranges {
            let bytes = (w * n * 4) as u64;
            if bytes > 0 {
                enc.copy_buffer_to_buffer(src, (c * n * 4) as u64, &staging, at, bytes);
            }
            at += bytes;
        }
        self.ctx.queue.submit([enc.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv().map_err(gpu_err)?.map_err(gpu_err)?;
        let view = staging.slice(..).get_mapped_range().map_err(gpu_err)?;
        let all: &[f32] = bytemuck::cast_slice(&view);
        let mut out = Vec::new();
        let mut at = 0;
        for &(_, w) in ranges {
            out.push(all[at..at + w * n].to_vec());
            at += w * n;
        }
        drop(view);
        staging.unmap();
        Ok(out)
    }

    /// Encodes and submits the passes `steps`, and waits for them.
    fn run_passes(
        &self,
        steps: &[usize],
        bufs: &Buffers,
        n: usize,
        mask: u32,
        times: &mut BatchTimes,
    ) -> Result<(), GpuError> {
        let mut enc = self.device().create_command_encoder(&Default::default());
        let mut any = false;
        for &s in steps {
            let (Some(Some(pg)), Some(Step::Pass(ps))) =
                (self.passes.get(s), self.plan.steps.get(s))
            else {
                continue;
            };
            if self.guard_fails(&ps.guard, mask) {
                continue;
            }
            let mut entries = vec![
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: bufs.uni.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: bufs.frag.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: bufs.out.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: bufs.tmp.as_entire_binding(),
                },
            ];
            if pg.lights {
                entries.push(wgpu::BindGroupEntry {
                    binding: 4,
                    resource: bufs.light.as_entire_binding(),
                });
            }
            if pg.textures {
                let Some((texels, info)) = &self.textures else {
                    return Err(GpuError::Runtime("textures were not uploaded".into()));
                };
                entries.push(wgpu::BindGroupEntry {
                    binding: 5,
                    resource: texels.as_entire_binding(),
                });
                entries.push(wgpu::BindGroupEntry {
                    binding: 6,
                    resource: info.as_entire_binding(),
                });
            }
            let bg = self.device().create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &pg.layout,
                entries: &entries,
            });
            let mut cp = enc.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
            cp.set_pipeline(&pg.pipeline);
            cp.set_bind_group(0, &bg, &[]);
            let wg = self.plan.options.workgroup_size as usize;
            cp.dispatch_workgroups(n.div_ceil(wg) as u32, 1, 1);
            drop(cp);
            times.passes += 1;
            any = true;
        }
        if any {
            let t = Instant::now();
            self.ctx.queue.submit([enc.finish()]);
            self.wait()?;
            times.kernels += t.elapsed();
        }
        Ok(())
    }

    /// One host step: read back what it needs, ask the scene, write the results.
    #[allow(clippy::too_many_arguments)]
    fn host_step(
        &self,
        step: &plan::HostStep,
        bufs: &Buffers,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &[Fragment],
        samples: usize,
    ) -> Result<(), GpuError> {
        let n = frags.len();
        let p = &self.program;
        let l = &self.plan.layout;
        if self.guard_fails(&step.guard, mask) {
            return Ok(());
        }
        // Without a scene, traces are black and occlusion is 1 wherever they run.
        if scene.is_none()
            && let HostKind::Trace(v) | HostKind::Occlusion(v) = &step.kind
        {
            if let Some(c) = l.tmp.get(v.index()).copied().flatten() {
                let (w, x) = match step.kind {
                    HostKind::Trace(_) => (3, 0.0f32),
                    _ => (1, 1.0f32),
                };
                let data = vec![x; w * n];
                self.ctx.queue.write_buffer(
                    &bufs.tmp,
                    (c * n * 4) as u64,
                    bytemuck::cast_slice(&data),
                );
            }
            return Ok(());
        }
        let ranges: Vec<(usize, usize)> = step
            .reads
            .iter()
            .map(|v| {
                let c = l.tmp.get(v.index()).copied().flatten().unwrap_or(0);
                (c, crate::emit::columns(p.ty(*v)))
            })
            .collect();
        let cols = self.read_columns(&bufs.tmp, &ranges, n)?;
        let hv = HostValues {
            m: self,
            env,
            mask,
            frags,
            read: step.reads.iter().copied().zip(cols).collect(),
        };
        match &step.kind {
            HostKind::Trace(v) => {
                let Op::Trace { dir, ray_type } = p.op(*v) else {
                    return Err(GpuError::Runtime("host step: not a trace".into()));
                };
                let mut aos = vec![[0.0f32; 3]; n];
                aos.par_iter_mut().enumerate().for_each(|(i, d)| {
                    if hv.holds(&step.guard, i) {
                        let f = &frags[i];
                        *d = interp::trace_radiance(
                            shadenet_runtime::fragment_services(scene, i),
                            f.p,
                            hv.vec3(*dir, i),
                            *ray_type,
                            f.ray_depth,
                        );
                    }
                });
                let mut soa = vec![0.0f32; 3 * n];
                for (i, c) in aos.iter().enumerate() {
                    for k in 0..3 {
                        soa[k * n + i] = c[k];
                    }
                }
                self.write_tmp(bufs, *v, n, &soa);
            }
            HostKind::Occlusion(v) => {
                let Op::Occlusion {
                    n: nv,
                    samples: sv,
                    max_distance,
                } = p.op(*v)
                else {
                    return Err(GpuError::Runtime("host step: not an occlusion".into()));
                };
                let mut out = vec![0.0f32; n];
                out.par_iter_mut().enumerate().for_each(|(i, d)| {
                    if hv.holds(&step.guard, i) {
                        let f = &frags[i];
                        *d = interp::occlusion_value(
                            shadenet_runtime::fragment_services(scene, i),
                            f.p,
                            hv.vec3(*nv, i),
                            hv.int(*sv, i),
                            hv.float(*max_distance, i),
                            f.seed,
                        );
                    }
                });
                self.write_tmp(bufs, *v, n, &out);
            }
            HostKind::LightSamples { region, set } => {
                let Op::Illuminance { p: point, .. } = p.op(*region) else {
                    return Err(GpuError::Runtime("host step: not a light loop".into()));
                };
                let ls = &l.light_sets[*set];
                let pt = |i: usize| hv.holds(&step.guard, i).then(|| hv.vec3(*point, i));
                let data = light_samples(env, frags, samples, ls.visible, scene, &pt);
                let off = LIGHT_COLUMNS * samples * set * n * 4;
                if !data.is_empty() {
                    self.ctx.queue.write_buffer(
                        &bufs.light,
                        off as u64,
                        bytemuck::cast_slice(&data),
                    );
                }
            }
        }
        Ok(())
    }

    fn write_tmp(&self, bufs: &Buffers, v: Value, n: usize, soa: &[f32]) {
        if let Some(c) = self.plan.layout.tmp.get(v.index()).copied().flatten()
            && !soa.is_empty()
        {
            self.ctx
                .queue
                .write_buffer(&bufs.tmp, (c * n * 4) as u64, bytemuck::cast_slice(soa));
        }
    }

    /// Shades one batch (at most [`Plan::max_batch`] fragments) into `out`.
    fn batch(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &[Fragment],
        out: &mut [f32],
        times: &mut BatchTimes,
    ) -> Result<u64, GpuError> {
        let n = frags.len();
        let l = &self.plan.layout;
        let samples = sample_total(env);
        let device = self.device();
        let scopes = [
            device.push_error_scope(wgpu::ErrorFilter::Validation),
            device.push_error_scope(wgpu::ErrorFilter::OutOfMemory),
            device.push_error_scope(wgpu::ErrorFilter::Internal),
        ];
        let result = self.batch_scoped(env, mask, scene, frags, out, times, samples, n, l);
        let mut errors = Vec::new();
        for s in scopes.into_iter().rev() {
            if let Some(e) = pollster::block_on(s.pop()) {
                errors.push(e.to_string());
            }
        }
        if !errors.is_empty() {
            return Err(GpuError::Runtime(errors.join("; ")));
        }
        result
    }

    #[allow(clippy::too_many_arguments)]
    fn batch_scoped(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &[Fragment],
        out: &mut [f32],
        times: &mut BatchTimes,
        samples: usize,
        n: usize,
        l: &plan::Layout,
    ) -> Result<u64, GpuError> {
        let device = self.device();
        // Upload.
        let t = Instant::now();
        let init = |label: &str, data: &[f32], usage: wgpu::BufferUsages| {
            let data: &[f32] = if data.is_empty() { &[0.0] } else { data };
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytemuck::cast_slice(data),
                usage,
            })
        };
        let zeroed = |label: &str, floats: usize, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (floats.max(1) * 4) as u64,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        let bufs = Buffers {
            uni: init("sn_uni", &self.uniforms(env, mask, n, samples), U::STORAGE),
            frag: init("sn_frag", &self.fragment_columns(frags), U::STORAGE),
            out: zeroed("sn_out", l.out_columns * n, U::STORAGE | U::COPY_SRC),
            tmp: zeroed(
                "sn_tmp",
                l.tmp_columns * n,
                U::STORAGE | U::COPY_SRC | U::COPY_DST,
            ),
            light: zeroed(
                "sn_light",
                self.plan.light_columns(samples) * n,
                U::STORAGE | U::COPY_DST,
            ),
        };
        times.upload += t.elapsed();

        // Light samples at P, before the first pass.
        if samples > 0
            && let Some(set) = l.light_sets.iter().position(|s| s.point.is_none())
        {
            let t = Instant::now();
            let visible = l.light_sets[set].visible;
            let pt = |i: usize| Some(frags[i].p);
            let data = light_samples(env, frags, samples, visible, scene, &pt);
            times.host += t.elapsed();
            let t = Instant::now();
            let off = LIGHT_COLUMNS * samples * set * n * 4;
            self.ctx
                .queue
                .write_buffer(&bufs.light, off as u64, bytemuck::cast_slice(&data));
            times.upload += t.elapsed();
        }

        // Passes and host steps, in order.
        let mut pending: Vec<usize> = Vec::new();
        for (s, step) in self.plan.steps.iter().enumerate() {
            match step {
                Step::Pass(_) => pending.push(s),
                Step::Host(h) => {
                    self.run_passes(&pending, &bufs, n, mask, times)?;
                    pending.clear();
                    let t = Instant::now();
                    if samples > 0 || !matches!(h.kind, HostKind::LightSamples { .. }) {
                        self.host_step(h, &bufs, env, mask, scene, frags, samples)?;
                    }
                    times.host += t.elapsed();
                }
            }
        }
        self.run_passes(&pending, &bufs, n, mask, times)?;

        // Readback and the output guard.
        let t = Instant::now();
        let w = l.out_columns;
        let cols = self
            .read_columns(&bufs.out, &[(0, w)], n)?
            .pop()
            .unwrap_or_default();
        let mut bad = 0u64;
        if w > 0 {
            for (i, dst) in out.chunks_mut(w).take(n).enumerate() {
                for (c, d) in dst.iter_mut().enumerate() {
                    let x = cols[c * n + i];
                    if x.is_finite() {
                        *d = x;
                    } else {
                        *d = 0.0;
                        bad += 1;
                    }
                }
            }
        }
        times.readback += t.elapsed();
        Ok(bad)
    }
}

impl Material for GpuMaterial {
    fn layout(&self) -> &[OutputSlot] {
        &self.layout
    }

    fn width(&self) -> usize {
        self.width
    }

    fn shade(&self, ctx: &ShadeCtx, out: &mut [f32]) -> u32 {
        self.companion.shade(ctx, out)
    }

    fn shade_x4(
        &self,
        env: &ShadeEnv,
        mask: u32,
        frags: &FragmentX4,
        active: usize,
        out: &mut [f32],
    ) -> u32 {
        self.companion.shade_x4(env, mask, frags, active, out)
    }

    fn info(&self) -> &MaterialInfo {
        &self.info
    }

    fn shade_many(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &[Fragment],
        out: &mut [f32],
    ) -> BatchResult {
        let mut result = BatchResult::default();
        let w = self.width;
        if frags.is_empty() || out.len() < w * frags.len() {
            if !frags.is_empty() {
                eprintln!(
                    "shadenet-gpu: material `{}`: shade_many got {} output floats for {} \
                     fragments of {w}; nothing shaded",
                    self.program.name,
                    out.len(),
                    frags.len()
                );
            }
            return result;
        }
        if w == 0 {
            return result;
        }
        let cap = self.plan.max_batch(sample_total(env));
        for (k, (chunk, dst)) in frags.chunks(cap).zip(out.chunks_mut(cap * w)).enumerate() {
            // Fragment `i` of the chunk is fragment `base + i` of the call.
            let offset = scene.map(|inner| ChunkServices {
                inner,
                base: k * cap,
            });
            let scene = match &offset {
                Some(o) if o.base > 0 => Some(o as &dyn SceneServices),
                _ => scene,
            };
            let ok = if self.failed.load(Ordering::Relaxed) {
                None
            } else {
                match self.batch(env, mask, scene, chunk, dst, &mut result.times) {
                    Ok(bad) => Some(bad),
                    Err(e) => {
                        if !self.failed.swap(true, Ordering::Relaxed) {
                            eprintln!(
                                "shadenet-gpu: material `{}`: {e}; shading on the companion \
                                 back end instead",
                                self.program.name
                            );
                        }
                        None
                    }
                }
            };
            match ok {
                Some(bad) => result.nonfinite += bad,
                None => {
                    let r = self.companion.shade_many(env, mask, scene, chunk, dst);
                    result.nonfinite += r.nonfinite;
                    result.times.add(&r.times);
                }
            }
        }
        result
    }
}
