//! The pass plan as data: how one program runs as GPU passes and host steps (docs/gpu.md,
//! "Plan").
//!
//! Owns: the plan's types, which the planner ([`crate::planner`]) fills in and the kernel
//! writer ([`crate::kernel`]) and the material ([`crate::material`]) read: the [`Item`]s of the
//! linearized program (values; an `If` as its arms' items under a [`Guard`] and a merge; an
//! `Illuminance` or a `Loop` as one atomic item), the [`HostStep`]s that cut the sequence, the
//! [`Pass`]es, the buffer layouts every kernel and the host agree on ([`Layout`], the uniform
//! slots `U_*`), how values are encoded in buffer columns ([`encode_const`]), and `Plan:
//! Display` (what `shadenet compile --emit wgsl --stats` prints).
//!
//! Must not touch: how a program is cut into a plan ([`crate::planner`]), the text of the
//! kernels ([`crate::kernel`]), wgpu devices, buffers and dispatch ([`crate::material`]).
//! It imports none of them: they all read this module.

use crate::options::{GpuOptions, PassMode};
use shadenet_graph::ir::{Op, Program, Stream, Value};
use shadenet_graph::types::ConstValue;
use shadenet_runtime::interp::OutputSlot;
use std::collections::HashMap;
use std::fmt;

/// Uniform slot of the fragment count `n` (its bits, as `u32`).
pub const U_N: usize = 0;
/// Uniform slot of the component mask (bits).
pub const U_MASK: usize = 1;
/// Uniform slot of the light sample count `S` per fragment (bits, `u32`).
pub const U_SAMPLES: usize = 2;
/// First of three uniform slots holding the ambient light's color.
pub const U_AMBIENT: usize = 3;
/// Uniform slot holding 0 (as bits): the kernels' value barrier (see `crate::kernel`).
pub const U_KEEP: usize = 6;
/// First uniform slot of the world → camera matrix (16 floats, row-major).
pub const U_CAMERA: usize = 8;
/// First uniform slot of the camera → world matrix.
pub const U_CAMERA_INV: usize = 24;
/// First uniform slot of the world → object matrix.
pub const U_OBJECT: usize = 40;
/// First uniform slot of the object → world matrix.
pub const U_OBJECT_INV: usize = 56;
/// First uniform slot after the fixed ones: prelude values, then parameters.
pub const U_VALUES: usize = 72;
/// Columns of one light sample in `sn_light`: L (3), Cl (3), visible (1), pdf (1).
pub const LIGHT_COLUMNS: usize = 8;
/// Storage buffers a kernel may bind at most (uni, frag, out, tmp, light, texels, tex info,
/// albedo tables).
pub const MAX_BINDINGS: u32 = 8;

/// The conditions an item runs under: each `(cond, polarity)` must hold (`cond == polarity`),
/// outermost first.
pub type Guard = Vec<(Value, bool)>;

/// What one item of the linearized program computes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ItemKind {
    /// One value (a pure op, a transform, a texture lookup).
    Value(Value),
    /// The results of an `If` whose arms ran as guarded items: each `proj` of the region is
    /// set to `select(else_yield, then_yield, cond)`.
    Merge(Value),
    /// A light loop, run whole in one kernel over the samples of light set `set`.
    Illuminance {
        /// The `Illuminance` value.
        region: Value,
        /// Index into [`Layout::light_sets`].
        set: usize,
    },
    /// A loop (`Op::Loop`), run whole in one kernel: its carried values in `var`s, its
    /// condition and body as structured WGSL inside a WGSL `loop` that also stops at
    /// `LOOP_ITERATION_LIMIT` body runs; each `proj` of the region reads its carried value
    /// once the loop is done.
    Loop {
        /// The `Loop` value.
        region: Value,
    },
}

/// One item of a pass: what it computes, under which guard, at which cost.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Item {
    /// What it computes.
    pub kind: ItemKind,
    /// When it runs.
    pub guard: Guard,
    /// Its op count (the cost model's unit).
    pub cost: usize,
}

/// What a host step does.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HostKind {
    /// `trace`: radiance from the scene along a direction, per fragment.
    Trace(Value),
    /// `occlusion`: ambient occlusion from the scene, per fragment.
    Occlusion(Value),
    /// The light samples of light set `set` (at a point other than the stream `P`), for the
    /// light loop `region`.
    LightSamples {
        /// The `Illuminance` value.
        region: Value,
        /// Index into [`Layout::light_sets`].
        set: usize,
    },
}

/// A step the host runs between passes: read values back, ask the scene, upload results.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HostStep {
    /// What it does.
    pub kind: HostKind,
    /// For which fragments (the others get zeros, or no samples).
    pub guard: Guard,
    /// Values it reads from `sn_tmp` (operands and guard conditions that the host cannot
    /// evaluate itself).
    pub reads: Vec<Value>,
}

/// One GPU pass: a kernel over every fragment of a batch.
#[derive(Clone, Debug, PartialEq)]
pub struct Pass {
    /// Its items, in order.
    pub items: Vec<Item>,
    /// The guard every item shares (the kernel returns early where it fails; the host skips
    /// the dispatch when it can tell it fails for all fragments).
    pub guard: Guard,
    /// Values it loads from `sn_tmp`.
    pub loads: Vec<Value>,
    /// Values it stores to `sn_tmp` for later steps.
    pub stores: Vec<Value>,
    /// Outputs it writes (indices into `Program::outputs`).
    pub outputs: Vec<usize>,
    /// Sum of its items' costs.
    pub cost: usize,
    /// Whether it runs a light loop (binds `sn_light`).
    pub lights: bool,
    /// Whether it reads textures (binds `sn_texels` and `sn_tex_info`).
    pub textures: bool,
    /// Whether it reads the albedo tables (binds `sn_tables`).
    pub tables: bool,
    /// Its WGSL kernel.
    pub wgsl: String,
}

/// One step of a plan.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// A GPU pass.
    Pass(Pass),
    /// A host step.
    Host(HostStep),
}

/// The light samples of one or more light loops at the same point.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LightSet {
    /// The point the samples are seen from: `None` for the stream `P` (computed by the host
    /// before the first pass), else the value a host step reads back first.
    pub point: Option<Value>,
    /// Whether some light loop of the set reads `light.visible` (then, with a scene, the host
    /// casts a shadow ray per sample).
    pub visible: bool,
}

/// Where everything lives in the buffers, shared by the kernels and the host.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    /// The streams in `sn_frag`, each with its first column, in [`Stream::ALL`] order.
    pub streams: Vec<(Stream, usize)>,
    /// The column of the fragment's seed (bits) in `sn_frag`.
    pub seed: usize,
    /// Columns of `sn_frag`.
    pub frag_columns: usize,
    /// The outputs in `sn_out` (the interpreter's layout).
    pub outputs: Vec<OutputSlot>,
    /// Columns of `sn_out`.
    pub out_columns: usize,
    /// First uniform slot of each prelude value, by arena index.
    pub prelude: HashMap<usize, usize>,
    /// First uniform slot of each parameter read outside the prelude, by parameter index.
    pub params: HashMap<u32, usize>,
    /// Slots of `sn_uni`.
    pub uniforms: usize,
    /// First `sn_tmp` column of each value that crosses a step boundary, by arena index.
    pub tmp: Vec<Option<usize>>,
    /// Columns of `sn_tmp`.
    pub tmp_columns: usize,
    /// Columns `sn_tmp` would take without reuse (the sum of the crossing values' widths).
    pub tmp_columns_no_reuse: usize,
    /// Light sets: each has `7 × S` columns in `sn_light`, set after set.
    pub light_sets: Vec<LightSet>,
    /// Whether some kernel reads textures.
    pub textures: bool,
    /// Whether some kernel reads the albedo tables.
    pub tables: bool,
}

/// A program planned for the GPU: steps, layouts, limits. See the module documentation.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The material's name.
    pub material: String,
    /// Passes and host steps, in order.
    pub steps: Vec<Step>,
    /// Buffer layouts.
    pub layout: Layout,
    /// The options it was planned with.
    pub options: GpuOptions,
    /// Most fragments per batch that the adapter's limits allow, light samples not counted
    /// (see [`Plan::max_batch`]).
    pub limit_batch: usize,
    /// The adapter's largest storage buffer binding, in bytes.
    pub binding_size: u64,
    /// Storage buffers per shader stage the adapter allows.
    pub buffers_per_stage: u32,
    /// Ops in the program (prelude and body).
    pub ops: usize,
    /// Printer names (`%N` of the IR text form) by arena index.
    pub(crate) names: Vec<Option<u32>>,
    /// For each region (by arena index): its `proj` users as (value, result index).
    pub(crate) projs: HashMap<usize, Vec<(Value, u8)>>,
    /// Step index that defines each value (by arena index), for values computed by a step.
    pub(crate) def: Vec<Option<usize>>,
    /// Columns of each value's type (0 for regions), by arena index.
    pub(crate) widths: Vec<usize>,
}

/// One WGSL kernel of a plan.
#[derive(Clone, Copy, Debug)]
pub struct Kernel<'a> {
    /// Its step index in [`Plan::steps`].
    pub step: usize,
    /// Its pass number (0, 1, …).
    pub pass: usize,
    /// The WGSL source.
    pub wgsl: &'a str,
}

impl Plan {
    /// The passes' kernels, in order.
    pub fn kernels(&self) -> Vec<Kernel<'_>> {
        let mut out = Vec::new();
        for (step, s) in self.steps.iter().enumerate() {
            if let Step::Pass(p) = s {
                out.push(Kernel {
                    step,
                    pass: out.len(),
                    wgsl: &p.wgsl,
                });
            }
        }
        out
    }

    /// Ops the passes compute in all (the cost model's unit; host steps count none). Every
    /// partition of a program computes the same ops.
    pub fn ops(&self) -> usize {
        self.steps
            .iter()
            .map(|s| match s {
                Step::Pass(p) => p.cost,
                Step::Host(_) => 0,
            })
            .sum()
    }

    /// Number of passes.
    pub fn passes(&self) -> usize {
        self.steps
            .iter()
            .filter(|s| matches!(s, Step::Pass(_)))
            .count()
    }

    /// Number of host steps.
    pub fn host_steps(&self) -> usize {
        self.steps.len() - self.passes()
    }

    /// Lines of WGSL, all kernels together.
    pub fn wgsl_lines(&self) -> usize {
        self.kernels().iter().map(|k| k.wgsl.lines().count()).sum()
    }

    /// Bytes of WGSL, all kernels together.
    pub fn wgsl_bytes(&self) -> usize {
        self.kernels().iter().map(|k| k.wgsl.len()).sum()
    }

    /// Columns of `sn_light` with `samples` light samples per fragment.
    pub fn light_columns(&self, samples: usize) -> usize {
        LIGHT_COLUMNS * samples * self.layout.light_sets.len()
    }

    /// Most fragments per batch with `samples` light samples per fragment: the adapter's
    /// limits (binding size of every per-fragment buffer, workgroups per dispatch) and
    /// [`GpuOptions::batch`]; at least 1.
    pub fn max_batch(&self, samples: usize) -> usize {
        let mut m = self.limit_batch.min(self.options.batch);
        let cols = self.light_columns(samples) as u64;
        if cols > 0 {
            m = m.min((self.binding_size / (4 * cols)) as usize);
        }
        m.max(1)
    }

    /// The `%N` name of a value (as `--emit ir` prints it).
    pub fn name(&self, v: Value) -> String {
        value_name(&self.names, v)
    }

    /// All kernels as one text, each after a comment line naming its pass (what
    /// `shadenet compile --emit wgsl` prints).
    pub fn wgsl(&self) -> String {
        let mut s = String::new();
        for k in self.kernels() {
            s.push_str(&format!(
                "// ---- material `{}`, pass {} (step {}) ----\n",
                self.material, k.pass, k.step
            ));
            s.push_str(k.wgsl);
            if !k.wgsl.ends_with('\n') {
                s.push('\n');
            }
        }
        s
    }
}

/// The `%N` name of a value by the printer's numbering `names` (`%vK`, its arena index, when
/// it has none).
pub(crate) fn value_name(names: &[Option<u32>], v: Value) -> String {
    match names.get(v.index()).copied().flatten() {
        Some(n) => format!("%{n}"),
        None => format!("%v{}", v.index()),
    }
}

/// How values are encoded in `f32` buffer columns (`sn_uni`, `sn_tmp`): floats as they are,
/// ints as their bits, bools as 0/1, strings as 0; matrices as 16 floats, row-major.
pub fn encode_const(c: &ConstValue) -> Vec<f32> {
    match c {
        ConstValue::Bool(b) => vec![if *b { 1.0 } else { 0.0 }],
        ConstValue::Int(i) => vec![f32::from_bits(*i as u32)],
        ConstValue::String(_) => vec![0.0],
        ConstValue::Float(x) => vec![*x as f32],
        ConstValue::Vec2(v) => v.iter().map(|x| *x as f32).collect(),
        ConstValue::Vec3(v) | ConstValue::Color(v) => v.iter().map(|x| *x as f32).collect(),
        ConstValue::Vec4(v) | ConstValue::Color4(v) => v.iter().map(|x| *x as f32).collect(),
        ConstValue::Matrix33(m) => m.iter().map(|x| *x as f32).collect(),
        ConstValue::Matrix44(m) => m.iter().map(|x| *x as f32).collect(),
    }
}

/// Whether a value is not computed by any step: constants, parameters, prelude values,
/// streams, the component mask, ambient light and the current light sample are read where
/// they are used (kernels load them from `sn_uni`/`sn_frag`/`sn_light`; the host evaluates
/// them itself).
pub(crate) fn is_remat(p: &Program, prelude: &HashMap<usize, usize>, v: Value) -> bool {
    prelude.contains_key(&v.index())
        || matches!(
            p.op(v),
            Op::Const(_)
                | Op::Param(_)
                | Op::Stream(_)
                | Op::ComponentEnabled(_)
                | Op::Ambient
                | Op::LightL
                | Op::LightCl
                | Op::LightVisible
                | Op::LightPdf
        )
}

fn guard_text(names: &[Option<u32>], g: &Guard) -> String {
    if g.is_empty() {
        return "-".into();
    }
    g.iter()
        .map(|(c, pol)| {
            let n = value_name(names, *c);
            if *pol { n } else { format!("!{n}") }
        })
        .collect::<Vec<_>>()
        .join(" && ")
}

impl Plan {
    fn values_text(&self, vs: &[Value]) -> String {
        if vs.is_empty() {
            return "-".into();
        }
        vs.iter()
            .map(|v| {
                let w = self
                    .layout
                    .tmp
                    .get(v.index())
                    .copied()
                    .flatten()
                    .zip(self.ty_width(*v));
                match w {
                    Some((c, w)) if w > 1 => format!("{}@{}..{}", self.name(*v), c, c + w),
                    Some((c, _)) => format!("{}@{}", self.name(*v), c),
                    None => self.name(*v),
                }
            })
            .collect::<Vec<_>>()
            .join(" ")
    }

    fn ty_width(&self, v: Value) -> Option<usize> {
        self.widths.get(v.index()).copied()
    }
}

impl fmt::Display for Plan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let l = &self.layout;
        let mode = match self.options.passes {
            PassMode::Auto => format!("auto, op budget {}", self.options.op_budget),
            PassMode::Fused => "fused".into(),
            PassMode::Count(n) => format!("{n} passes asked"),
        };
        writeln!(
            f,
            "gpu plan of `{}`: {} passes, {} host steps ({mode})",
            self.material,
            self.passes(),
            self.host_steps()
        )?;
        let streams: Vec<&str> = l.streams.iter().map(|(s, _)| s.name()).collect();
        writeln!(
            f,
            "  sn_frag: {} columns ({} seed); sn_out: {} columns; sn_uni: {} floats",
            l.frag_columns,
            streams.join(" "),
            l.out_columns,
            l.uniforms
        )?;
        if !l.light_sets.is_empty() {
            let sets: Vec<String> = l
                .light_sets
                .iter()
                .map(|s| {
                    let at = s.point.map_or("P".to_string(), |v| self.name(v));
                    if s.visible {
                        format!("at {at} with shadow rays")
                    } else {
                        format!("at {at}")
                    }
                })
                .collect();
            writeln!(f, "  light sets: {}", sets.join("; "))?;
        }
        let mut pass_no = 0;
        for (s, st) in self.steps.iter().enumerate() {
            match st {
                Step::Pass(ps) => {
                    let outs: Vec<String> = ps
                        .outputs
                        .iter()
                        .map(|&k| {
                            let o = &l.outputs[k];
                            format!("{}@{}", o.name, o.offset)
                        })
                        .collect();
                    writeln!(
                        f,
                        "  pass {pass_no} (step {s}): {} ops in {} items, guard {}, loads {}, \
                         stores {}, outputs {}{}{}{}, {} WGSL lines",
                        ps.cost,
                        ps.items.len(),
                        guard_text(&self.names, &ps.guard),
                        self.values_text(&ps.loads),
                        self.values_text(&ps.stores),
                        if outs.is_empty() {
                            "-".into()
                        } else {
                            outs.join(" ")
                        },
                        if ps.lights { ", light loop" } else { "" },
                        if ps.textures { ", textures" } else { "" },
                        if ps.tables { ", albedo tables" } else { "" },
                        ps.wgsl.lines().count()
                    )?;
                    pass_no += 1;
                }
                Step::Host(h) => {
                    let what = match &h.kind {
                        HostKind::Trace(v) => format!("trace {}", self.name(*v)),
                        HostKind::Occlusion(v) => format!("occlusion {}", self.name(*v)),
                        HostKind::LightSamples { region, set } => {
                            format!("light samples (set {set}) for {}", self.name(*region))
                        }
                    };
                    let writes = match &h.kind {
                        HostKind::Trace(v) | HostKind::Occlusion(v) => self.values_text(&[*v]),
                        HostKind::LightSamples { set, .. } => format!("sn_light set {set}"),
                    };
                    writeln!(
                        f,
                        "  host (step {s}): {what}, guard {}, reads {}, writes {writes}",
                        guard_text(&self.names, &h.guard),
                        self.values_text(&h.reads),
                    )?;
                }
            }
        }
        let cost = self.ops();
        writeln!(
            f,
            "  sn_tmp: {} columns ({} without reuse); at most {} fragments per batch \
             (binding size {} bytes, {} storage buffers per stage)",
            l.tmp_columns,
            l.tmp_columns_no_reuse,
            self.limit_batch.min(self.options.batch),
            self.binding_size,
            self.buffers_per_stage
        )?;
        writeln!(
            f,
            "  total: {} ops of {} in {} passes and {} host steps; {} WGSL lines, {} bytes",
            cost,
            self.ops,
            self.passes(),
            self.host_steps(),
            self.wgsl_lines(),
            self.wgsl_bytes()
        )
    }
}
