//! [`GpuBackend`] (a `runtime::Backend`) and [`GpuMaterial`] (a `runtime::Material`).
//!
//! Owns: compiling a program for the device (its [`crate::plan`](mod@crate::plan), one compute pipeline per
//! pass, the textures uploaded once, the uniform values the prelude and the parameters give,
//! the scalar companion material), and running a batch ([`Material::shade_many`]): the
//! buffers of each call, the uploads (streams and seed as structure of arrays, uniforms,
//! light samples computed on the host with rayon), the passes and host steps in order (a
//! host step reads the columns it needs back, asks each fragment's own services
//! (`SceneServices::fragment`) where its guard holds, and writes the results into
//! `sn_tmp`), the readback of `sn_out`, the output guard
//! (non-finite → 0, counted) and the time split ([`BatchTimes`](shadenet_runtime::backend::BatchTimes)). Single fragments
//! ([`Material::shade`], [`Material::shade_x4`]) go to the companion: a dispatch per fragment
//! would cost more than the shading.
//!
//! A program the plan cannot run (or a kernel the device rejects) becomes the interpreter,
//! marked as a fallback, with one line on standard error, as the JIT does
//! ([`GpuBackend::without_fallback`] makes it an error instead). A device error while
//! shading a batch (out of memory, a lost device) shades that batch with the companion
//! instead, saying so once per material.
//!
//! Here: the back end, compiling a material, the `Material` impl (chunks of a `shade_many`
//! call, the fallback to the companion). `batch` runs one batch, `host` its host steps,
//! `buffers` what goes into and comes out of its device buffers.
//!
//! Must not touch: what the kernels contain ([`crate::kernel`]) or how the program is cut
//! ([`crate::planner`]); the scene helpers it calls live in `shadenet_runtime`.

mod batch;
mod buffers;
mod host;

use crate::context::{GpuContext, GpuError};
pub use crate::options::{GpuOptions, PassMode};
use crate::plan::{Plan, Step, U_VALUES, encode_const};
use crate::planner;
use shadenet_graph::ir::Program;
use shadenet_graph::ops::Val;
use shadenet_graph::types::Type;
use shadenet_runtime::backend::{BatchResult, CompileStats, MaterialInfo};
use shadenet_runtime::interp::{self, Interpreter, OutputSlot};
use shadenet_runtime::texture::TextureSet;
use shadenet_runtime::{
    Backend, BackendError, Fragment, FragmentX4, Fragments, InterpMaterial, Material,
    SceneServices, ShadeCtx, ShadeEnv, lights, packed_index, packed_len,
};
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
    tables: bool,
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
    /// `sn_tables` (`emit::albedo_tables`), when a pass reads the albedo tables.
    tables: Option<wgpu::Buffer>,
    /// The uniform slots from [`U_VALUES`] on: prelude values and parameters.
    statics: Vec<f32>,
    companion: Arc<dyn Material>,
    layout: Vec<OutputSlot>,
    width: usize,
    info: MaterialInfo,
    /// Set once a batch failed on the device (the message is printed once).
    failed: AtomicBool,
    /// Device buffers kept between batches and calls (one set per batch in flight).
    pool: std::sync::Mutex<Vec<buffers::Buffers>>,
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

/// Encodes an interpreter value into buffer columns (see [`encode_const`]).
fn encode_val(v: &Val<f32>, mats: &[[f32; 16]], ty: Type) -> Vec<f32> {
    let mut out = match v {
        Val::Bool(b) => vec![if *b { 1.0 } else { 0.0 }],
        Val::Int(i) => vec![f32::from_bits(*i as u32)],
        Val::Float(x) => vec![*x],
        Val::Vec2(x) => x.to_vec(),
        Val::Vec3(x) => x.to_vec(),
        Val::Vec4(x) => x.to_vec(),
        Val::Mat(i) => mats.get(*i as usize).map_or(vec![0.0; 16], |m| m.to_vec()),
    };
    out.resize(crate::emit::columns(ty), 0.0);
    out
}

/// A storage buffer entry of a compute bind group layout.
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
        let t = Instant::now();
        let plan = planner::plan(program, options, &ctx.limits)?;
        let lower = t.elapsed();

        let textures = TextureSet::load(&program.textures)?;
        let statics = statics(program, &plan, &textures);

        // Pipelines, under error scopes: a kernel the device rejects is an error, not a
        // panic.
        let t = Instant::now();
        let device = &ctx.device;
        let (made, errors) = with_error_scopes(device, || {
            let passes = pipelines(device, program, &plan);
            let tex = upload_textures(device, program, &plan, &textures)?;
            let tables = plan.layout.tables.then(|| {
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("sn_tables"),
                    contents: bytemuck::cast_slice(crate::emit::albedo_tables()),
                    usage: wgpu::BufferUsages::STORAGE,
                })
            });
            Ok::<_, BackendError>((passes, tex, tables))
        });
        let (passes, tex, tables) = made?;
        if !errors.is_empty() {
            return Err(BackendError::Codegen {
                backend: "gpu",
                material: program.name.clone(),
                message: format!("the device rejects the kernels: {}", errors.join("; ")),
            });
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
            tables,
            statics,
            companion,
            layout,
            width,
            info,
            failed: AtomicBool::new(false),
            pool: std::sync::Mutex::new(Vec::new()),
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
}

/// The uniform slots from [`U_VALUES`] on: the prelude's values (computed once by the
/// interpreter) and the parameters' defaults, encoded as the kernels read them.
fn statics(program: &Program, plan: &Plan, textures: &TextureSet) -> Vec<f32> {
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
    statics
}

/// One compute pipeline per pass of the plan (`None` for host steps), each with its bind
/// group layout: the four buffers every kernel binds, `sn_light`, the textures and the albedo
/// tables where the pass reads them.
fn pipelines(device: &wgpu::Device, program: &Program, plan: &Plan) -> Vec<Option<PassGpu>> {
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
        if ps.tables {
            entries.push(storage_entry(crate::emit::TABLES_BINDING, true));
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
            tables: ps.tables,
        }));
        pass_no += 1;
    }
    passes
}

/// `sn_texels` and `sn_tex_info` on the device, when a pass reads textures; an error when
/// they do not fit in one binding.
fn upload_textures(
    device: &wgpu::Device,
    program: &Program,
    plan: &Plan,
    textures: &TextureSet,
) -> Result<Option<(wgpu::Buffer, wgpu::Buffer)>, BackendError> {
    if !plan.layout.textures {
        return Ok(None);
    }
    let unsupported = |reason: String| BackendError::Unsupported {
        backend: "gpu",
        material: program.name.clone(),
        op: "texture".into(),
        reason,
    };
    let (texels, info) =
        crate::textures::texture_buffers(program.textures.len(), textures).map_err(unsupported)?;
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
    Ok(Some((a, b)))
}

/// Runs `f` under validation, out-of-memory and internal error scopes of `device`: its
/// result, and the errors the scopes caught (innermost first).
fn with_error_scopes<T>(device: &wgpu::Device, f: impl FnOnce() -> T) -> (T, Vec<String>) {
    let scopes = [
        device.push_error_scope(wgpu::ErrorFilter::Validation),
        device.push_error_scope(wgpu::ErrorFilter::OutOfMemory),
        device.push_error_scope(wgpu::ErrorFilter::Internal),
    ];
    let result = f();
    let mut errors = Vec::new();
    for s in scopes.into_iter().rev() {
        if let Some(e) = pollster::block_on(s.pop()) {
            errors.push(e.to_string());
        }
    }
    (result, errors)
}

/// A chunk of a `shade_many` call's fragments: fragment `i` of the chunk is fragment
/// `base + i` of the call.
struct ChunkServices<'a> {
    inner: &'a dyn SceneServices,
    base: usize,
}

impl SceneServices for ChunkServices<'_> {
    fn trace(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        ray_type: i32,
        depth: i32,
        bsdf_pdf: f32,
    ) -> [f32; 3] {
        self.inner.trace(origin, dir, ray_type, depth, bsdf_pdf)
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

/// The light samples one fragment sees per shading call.
fn sample_total(env: &ShadeEnv) -> usize {
    env.lights
        .iter()
        .map(|l| lights::sample_count(l) as usize)
        .sum()
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
        frags: &Fragments,
        out: &mut [f32],
    ) -> BatchResult {
        let mut result = BatchResult::default();
        let (w, n) = (self.width, frags.len());
        if n == 0 || out.len() < packed_len(w, n) {
            if n != 0 {
                eprintln!(
                    "shadenet-gpu: material `{}`: shade_many got {} output floats for {n} \
                     fragments of {w}; nothing shaded",
                    self.program.name,
                    out.len(),
                );
            }
            return result;
        }
        if w == 0 {
            return result;
        }
        // The device reads columns per stream and writes fragment after fragment: each
        // batch's columns are written straight from the packets and its outputs straight
        // into the packets' layout. Host steps and light samples read fragments as structs:
        // only then is a batch unpacked (into one vector reused across batches).
        let cap = self.plan.max_batch(sample_total(env));
        let unpack = sample_total(env) > 0 || self.plan.host_steps() > 0;
        let mut aos: Vec<Fragment> = Vec::new();
        for (k, base) in (0..n).step_by(cap.max(1)).enumerate() {
            let len = cap.min(n - base);
            if unpack {
                let t = Instant::now();
                aos.clear();
                aos.extend((base..base + len).map(|i| frags.get(i)));
                result.times.upload += t.elapsed();
            }
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
                let input = (frags, base, len);
                match self.batch(env, mask, scene, input, &aos, out, &mut result.times) {
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
                    let chunk: Vec<Fragment> = (base..base + len).map(|i| frags.get(i)).collect();
                    let mut flat = vec![0.0f32; w * len];
                    let r = shadenet_runtime::shade_many_unpacked(
                        &*self.companion,
                        env,
                        mask,
                        scene,
                        &chunk,
                        &mut flat,
                    );
                    for (i, px) in flat.chunks(w).enumerate() {
                        for (c, x) in px.iter().enumerate() {
                            out[packed_index(w, base + i, c)] = *x;
                        }
                    }
                    result.nonfinite += r.nonfinite;
                    result.times.add(&r.times);
                }
            }
        }
        result
    }
}
