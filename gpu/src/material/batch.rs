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
use shadenet_runtime::{Fragment, Fragments, SceneServices, ShadeEnv};
use std::time::Instant;

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
            if pg.tables {
                let Some(tables) = &self.tables else {
                    return Err(GpuError::Runtime(
                        "the albedo tables were not uploaded".into(),
                    ));
                };
                entries.push(wgpu::BindGroupEntry {
                    binding: crate::emit::TABLES_BINDING,
                    resource: tables.as_entire_binding(),
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

    /// Shades one batch (at most [`Plan::max_batch`] fragments): fragments `base .. base +
    /// n` of `frags` (`aos`: the same fragments unpacked, where the plan has host steps or
    /// light samples; empty otherwise), written into `out` (the whole call's output, in the
    /// packets' layout). Returns how many values the output guard zeroed.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn batch(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        (frags, base, n): (&Fragments, usize, usize),
        aos: &[Fragment],
        out: &mut [f32],
        times: &mut BatchTimes,
    ) -> Result<u64, GpuError> {
        let (result, errors) = with_error_scopes(self.device(), || {
            self.batch_scoped(env, mask, scene, (frags, base, n), aos, out, times)
        });
        if !errors.is_empty() {
            return Err(GpuError::Runtime(errors.join("; ")));
        }
        result
    }

    /// [`Self::batch`] inside the device's error scopes.
    #[allow(clippy::too_many_arguments)]
    fn batch_scoped(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        (frags, base, n): (&Fragments, usize, usize),
        aos: &[Fragment],
        out: &mut [f32],
        times: &mut BatchTimes,
    ) -> Result<u64, GpuError> {
        let samples = sample_total(env);
        // Upload: the kept buffers (cleared), the uniforms, the fragments' columns.
        let t = Instant::now();
        let mut bufs = self.take_buffers(n, samples, &self.uniforms(env, mask, n, samples));
        let r = self.write_fragment_columns(&mut bufs, frags, base, n);
        times.upload += t.elapsed();
        let r = r.and_then(|()| self.run_steps(env, mask, scene, aos, n, &bufs, times));
        // Readback and the output guard, straight into the packets' layout.
        let r = r.and_then(|()| {
            let t = Instant::now();
            let bad = self.read_outputs(&bufs, n, base, out);
            times.readback += t.elapsed();
            bad
        });
        self.keep_buffers(bufs);
        r
    }

    /// The light samples at `P`, then the passes and host steps in order.
    #[allow(clippy::too_many_arguments)]
    fn run_steps(
        &self,
        env: &ShadeEnv,
        mask: u32,
        scene: Option<&dyn SceneServices>,
        frags: &[Fragment],
        n: usize,
        bufs: &Buffers,
        times: &mut BatchTimes,
    ) -> Result<(), GpuError> {
        let l = &self.plan.layout;
        let samples = sample_total(env);
        // Light samples at P, before the first pass.
        if samples > 0
            && let Some(set) = l.light_sets.iter().position(|s| s.point.is_none())
        {
            let t = Instant::now();
            let visible = l.light_sets[set].visible;
            let pt = |i: usize| Some(frags[i].p);
            let mut scratch = bufs.light_scratch.lock().map_err(super::buffers::gpu_err)?;
            let data = light_samples(env, frags, samples, visible, scene, &pt, &mut scratch);
            times.host += t.elapsed();
            let t = Instant::now();
            let off = LIGHT_COLUMNS * samples * set * n * 4;
            self.ctx
                .queue
                .write_buffer(&bufs.light, off as u64, bytemuck::cast_slice(data));
            times.upload += t.elapsed();
        }

        // Passes and host steps, in order.
        let mut pending: Vec<usize> = Vec::new();
        for (s, step) in self.plan.steps.iter().enumerate() {
            match step {
                Step::Pass(_) => pending.push(s),
                Step::Host(h) => {
                    self.run_passes(&pending, bufs, n, mask, times)?;
                    pending.clear();
                    let t = Instant::now();
                    if samples > 0 || !matches!(h.kind, HostKind::LightSamples { .. }) {
                        self.host_step(h, bufs, env, mask, scene, frags, samples)?;
                    }
                    times.host += t.elapsed();
                }
            }
        }
        self.run_passes(&pending, bufs, n, mask, times)
    }
}
