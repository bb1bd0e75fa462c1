//! What goes into one batch's device buffers and what comes out: the per-call uniforms,
//! the fragments' streams as structure of arrays, column read-back and `sn_tmp` writes, and
//! what the host can tell of a uniform bool without the device.
//!
//! Must not touch: the order of passes and host steps ([`super::batch`]), what a host step
//! computes ([`super::host`]).

use super::GpuMaterial;
use crate::context::GpuError;
use crate::plan::{
    Guard, U_AMBIENT, U_CAMERA, U_CAMERA_INV, U_KEEP, U_MASK, U_N, U_OBJECT, U_OBJECT_INV,
    U_SAMPLES, U_VALUES, encode_const,
};
use shadenet_graph::ir::{Op, Stream, Value};
use shadenet_runtime::{Fragment, ShadeEnv, lights};

/// A device error as [`GpuError::Runtime`].
pub(super) fn gpu_err(e: impl std::fmt::Display) -> GpuError {
    GpuError::Runtime(e.to_string())
}

impl GpuMaterial {
    /// The value of a uniform bool the host can tell without the device (constants,
    /// parameters, prelude values, component queries); `None` for the others.
    pub(super) fn uniform_bool(&self, v: Value, mask: u32) -> Option<bool> {
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
    pub(super) fn guard_fails(&self, guard: &Guard, mask: u32) -> bool {
        guard
            .iter()
            .any(|&(c, pol)| self.uniform_bool(c, mask) == Some(!pol))
    }

    /// The per-call uniforms.
    pub(super) fn uniforms(&self, env: &ShadeEnv, mask: u32, n: usize, samples: usize) -> Vec<f32> {
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
    pub(super) fn fragment_columns(&self, frags: &[Fragment]) -> Vec<f32> {
        let n = frags.len();
        let l = &self.plan.layout;
        let mut d = vec![0.0f32; l.frag_columns * n];
        for &(s, c0) in &l.streams {
            for (i, f) in frags.iter().enumerate() {
                let (vals, len) = stream_columns(s, f);
                for (k, x) in vals[..len].iter().enumerate() {
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

/// The columns of a stream of a fragment (ints as their bits): the first `len` floats of the
/// array (no allocation: this runs per fragment and stream).
pub(super) fn stream_columns(s: Stream, f: &Fragment) -> ([f32; 4], usize) {
    let pad3 = |v: [f32; 3]| ([v[0], v[1], v[2], 0.0], 3);
    match s {
        Stream::P => pad3(f.p),
        Stream::N => pad3(f.n),
        Stream::Ng => pad3(f.ng),
        Stream::I => pad3(f.i),
        Stream::Uv => ([f.uv[0], f.uv[1], 0.0, 0.0], 2),
        Stream::DPdu => pad3(f.dpdu),
        Stream::DPdv => pad3(f.dpdv),
        Stream::DPdx => pad3(f.dpdx),
        Stream::DPdy => pad3(f.dpdy),
        Stream::Time => ([f.time, 0.0, 0.0, 0.0], 1),
        Stream::RayType => ([f32::from_bits(f.ray_type as u32), 0.0, 0.0, 0.0], 1),
        Stream::RayDepth => ([f32::from_bits(f.ray_depth as u32), 0.0, 0.0, 0.0], 1),
        Stream::Rand => (f.rand, 4),
    }
}

/// One batch's device buffers.
pub(super) struct Buffers {
    /// `sn_uni`: the uniforms.
    pub uni: wgpu::Buffer,
    /// `sn_frag`: the fragments' streams and seeds.
    pub frag: wgpu::Buffer,
    /// `sn_out`: the outputs.
    pub out: wgpu::Buffer,
    /// `sn_tmp`: the values that cross a step boundary.
    pub tmp: wgpu::Buffer,
    /// `sn_light`: the light samples.
    pub light: wgpu::Buffer,
}

impl GpuMaterial {
    /// The device.
    pub(super) fn device(&self) -> &wgpu::Device {
        &self.ctx.device
    }

    /// Waits until the device has finished all submitted work.
    pub(super) fn wait(&self) -> Result<(), GpuError> {
        self.device()
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(gpu_err)
    }

    /// Copies column ranges `(first column, columns)` of `src` (columns of `n` floats) back
    /// to the host: one vector per range.
    pub(super) fn read_columns(
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

    /// Writes the columns `soa` of value `v` into `sn_tmp` (where the layout gives it
    /// columns).
    pub(super) fn write_tmp(&self, bufs: &Buffers, v: Value, n: usize, soa: &[f32]) {
        if let Some(c) = self.plan.layout.tmp.get(v.index()).copied().flatten()
            && !soa.is_empty()
        {
            self.ctx
                .queue
                .write_buffer(&bufs.tmp, (c * n * 4) as u64, bytemuck::cast_slice(soa));
        }
    }
}
