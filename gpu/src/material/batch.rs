//! One batch on the device: its buffers made and filled, the light samples at `P`, the
//! passes and host steps in order, the read-back of `sn_out` and the output guard
//! (non-finite → 0, counted), with the time split ([`BatchTimes`]).
//!
//! Must not touch: what a host step computes ([`super::host`]), how columns are encoded
//! ([`super::buffers`]), the chunking of a call and the fallback ([`super`]).

use super::buffers::Buffers;
use super::host::light_samples;
use super::{GpuMaterial, sample_total, with_error_scopes};
use crate::context::GpuError;
use crate::plan::{HostKind, LIGHT_COLUMNS, Step};
use shadenet_runtime::backend::BatchTimes;
use shadenet_runtime::{Fragment, SceneServices, ShadeEnv};
use std::time::Instant;
use wgpu::util::DeviceExt;

impl GpuMaterial {
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

    /// Shades one batch (at most [`Plan::max_batch`] fragments) into `out`.
    pub(super) fn batch(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &[Fragment],
        out: &mut [f32],
        times: &mut BatchTimes,
    ) -> Result<u64, GpuError> {
        let (result, errors) = with_error_scopes(self.device(), || {
            self.batch_scoped(env, mask, scene, frags, out, times)
        });
        if !errors.is_empty() {
            return Err(GpuError::Runtime(errors.join("; ")));
        }
        result
    }

    /// [`Self::batch`] inside the device's error scopes.
    fn batch_scoped(
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
