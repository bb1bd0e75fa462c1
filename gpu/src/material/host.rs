//! The host steps of a batch: what the device cannot do (`trace`, `occlusion`, light samples
//! with shadow rays), run on the host over the fragments where the step's guard holds.
//!
//! Owns: the values a host step reads (read back from `sn_tmp` or known to the host), the
//! light samples of a light set, and one host step from read-back to `sn_tmp` or `sn_light`
//! write. Must not touch: the order of steps ([`super::batch`]) or the buffers' contents
//! beyond the step's own columns ([`super::buffers`]).

use super::GpuMaterial;
use super::buffers::{Buffers, stream_columns};
use crate::context::GpuError;
use crate::plan::{Guard, HostKind, HostStep, LIGHT_COLUMNS, U_VALUES, encode_const};
use rayon::prelude::*;
use shadenet_graph::ir::{Op, Value};
use shadenet_runtime::interp;
use shadenet_runtime::{Fragment, SceneServices, ShadeEnv, lights};
use std::collections::HashMap;

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
            Op::Stream(s) => {
                let (v, len) = stream_columns(*s, &self.frags[i]);
                v[..len].to_vec()
            }
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

    fn holds(&self, guard: &Guard, i: usize) -> bool {
        guard
            .iter()
            .all(|&(c, pol)| (self.float(c, i) != 0.0) == pol)
    }
}

/// Light samples of every fragment as seen from `point(i)` (`None`: no samples, zeros),
/// structure of arrays: column `7 j + c` of sample `j`; in `scratch.1` (`scratch.0` holds
/// them fragment after fragment first; both vectors are kept by the batch's buffers, so
/// that a batch allocates nothing once they are large enough).
pub(super) fn light_samples<'s>(
    env: &ShadeEnv,
    frags: &[Fragment],
    samples: usize,
    visible: bool,
    scene: Option<&dyn SceneServices>,
    point: &(dyn Fn(usize) -> Option<[f32; 3]> + Sync),
    scratch: &'s mut (Vec<f32>, Vec<f32>),
) -> &'s [f32] {
    let n = frags.len();
    let w = LIGHT_COLUMNS * samples;
    let (aos, soa) = scratch;
    aos.clear();
    aos.resize(w * n, 0.0);
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
                    d[7] = s.pdf;
                    j += 1;
                }
            }
        });
    soa.resize(w * n, 0.0);
    for i in 0..n {
        for c in 0..w {
            soa[c * n + i] = aos[i * w + c];
        }
    }
    &soa[..w * n]
}

impl GpuMaterial {
    /// One host step: read back what it needs, ask the scene, write the results.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn host_step(
        &self,
        step: &HostStep,
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
        let cols = self.read_columns(bufs, &bufs.tmp, &ranges, n)?;
        let hv = HostValues {
            m: self,
            env,
            mask,
            frags,
            read: step.reads.iter().copied().zip(cols).collect(),
        };
        match &step.kind {
            HostKind::Trace(v) => {
                let Op::Trace { dir, ray_type, pdf } = p.op(*v) else {
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
                            pdf.map_or(0.0, |q| hv.float(q, i)),
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
                let mut scratch = bufs.light_scratch.lock().map_err(super::buffers::gpu_err)?;
                let data = light_samples(env, frags, samples, ls.visible, scene, &pt, &mut scratch);
                let off = LIGHT_COLUMNS * samples * set * n * 4;
                if !data.is_empty() {
                    self.ctx.queue.write_buffer(
                        &bufs.light,
                        off as u64,
                        bytemuck::cast_slice(data),
                    );
                }
            }
        }
        Ok(())
    }
}
