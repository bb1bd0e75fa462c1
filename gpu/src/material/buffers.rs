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
use shadenet_runtime::packets::{FragmentX4, LANES};
use shadenet_runtime::{Fragment, Fragments, ShadeEnv, lights, packed_index};
use std::sync::Mutex;

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

    /// Writes the streams and seeds of fragments `base .. base + n` of `frags`, structure
    /// of arrays (column `c` at `c * n`), from the packets into `sn_frag` through the
    /// buffers' kept host vector (no allocation once it is large enough).
    pub(super) fn write_fragment_columns(
        &self,
        bufs: &mut Buffers,
        frags: &Fragments,
        base: usize,
        n: usize,
    ) -> Result<(), GpuError> {
        let l = &self.plan.layout;
        let floats = l.frag_columns * n;
        if floats == 0 {
            return Ok(());
        }
        let mut d = std::mem::take(&mut bufs.scratch);
        d.resize(floats, 0.0);
        let packets = frags.packets();
        let lanes = |col: &mut [f32], get: &dyn Fn(&FragmentX4) -> [f32; LANES]| {
            for (i, x) in col.iter_mut().enumerate() {
                let g = base + i;
                *x = get(&packets[g / LANES])[g % LANES];
            }
        };
        for &(s, c0) in &l.streams {
            for k in 0..stream_len(s) {
                let col = &mut d[(c0 + k) * n..(c0 + k + 1) * n];
                lanes(col, &|p: &FragmentX4| packet_lanes(s, p, k));
            }
        }
        let seed = &mut d[l.seed * n..(l.seed + 1) * n];
        lanes(seed, &|p: &FragmentX4| p.seed.map(f32::from_bits));
        self.ctx
            .queue
            .write_buffer(&bufs.frag, 0, bytemuck::cast_slice(&d[..floats]));
        bufs.scratch = d;
        Ok(())
    }
}

/// How many columns a stream has.
fn stream_len(s: Stream) -> usize {
    match s {
        Stream::Uv => 2,
        Stream::Time | Stream::RayType | Stream::RayDepth => 1,
        Stream::Rand => 4,
        _ => 3,
    }
}

/// Column `k` of a stream in the four lanes of a packet (ints as their bits).
fn packet_lanes(s: Stream, p: &FragmentX4, k: usize) -> [f32; LANES] {
    let ints = |v: [i32; LANES]| v.map(|x| f32::from_bits(x as u32));
    match s {
        Stream::P => p.p[k],
        Stream::N => p.n[k],
        Stream::Ng => p.ng[k],
        Stream::I => p.i[k],
        Stream::Uv => p.uv[k],
        Stream::DPdu => p.dpdu[k],
        Stream::DPdv => p.dpdv[k],
        Stream::DPdx => p.dpdx[k],
        Stream::DPdy => p.dpdy[k],
        Stream::Time => p.time,
        Stream::RayType => ints(p.ray_type),
        Stream::RayDepth => ints(p.ray_depth),
        Stream::Rand => p.rand[k],
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

/// One batch's device buffers, kept by the material between batches and calls
/// ([`GpuMaterial::take_buffers`]): created on the first batch, grown when a batch needs
/// more, cleared (not recreated) before each batch.
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
    /// The mappable buffer read-backs copy into (made on the first read-back, grown when
    /// one needs more).
    staging: Mutex<Option<wgpu::Buffer>>,
    /// The host vector the fragments' columns are gathered into.
    scratch: Vec<f32>,
    /// The host vectors light samples are computed in ([`super::host::light_samples`]).
    pub light_scratch: Mutex<(Vec<f32>, Vec<f32>)>,
}

/// The most device memory a material keeps between batches (one set of [`Buffers`]; a
/// larger set is made for its batch and dropped after it).
const KEEP_BYTES: u64 = 256 << 20;

/// The byte sizes one batch of `n` fragments needs, in [`Buffers`]' field order (uni,
/// frag, out, tmp, light); at least 4 each (wgpu refuses empty bindings).
fn sizes(m: &GpuMaterial, n: usize, samples: usize) -> [u64; 5] {
    let l = &m.plan.layout;
    [
        l.uniforms.max(U_VALUES),
        l.frag_columns * n,
        l.out_columns * n,
        l.tmp_columns * n,
        m.plan.light_columns(samples) * n,
    ]
    .map(|floats| (floats.max(1) * 4) as u64)
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

    /// A set of buffers for a batch of `n` fragments: one the material kept from an
    /// earlier batch (each buffer grown where it is too small), or new ones. The used
    /// ranges of `sn_out`, `sn_tmp` and `sn_light` are cleared on the device (as new
    /// buffers are zero), and the uniforms written. Give them back with
    /// [`Self::keep_buffers`].
    pub(super) fn take_buffers(&self, n: usize, samples: usize, uniforms: &[f32]) -> Buffers {
        let need = sizes(self, n, samples);
        let kept = self.pool.lock().map(|mut p| p.pop()).unwrap_or(None);
        let device = self.device();
        use wgpu::BufferUsages as U;
        let usage = [
            U::STORAGE | U::COPY_DST,
            U::STORAGE | U::COPY_DST,
            U::STORAGE | U::COPY_SRC | U::COPY_DST,
            U::STORAGE | U::COPY_SRC | U::COPY_DST,
            U::STORAGE | U::COPY_DST,
        ];
        let labels = ["sn_uni", "sn_frag", "sn_out", "sn_tmp", "sn_light"];
        let make = |k: usize| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(labels[k]),
                size: need[k],
                usage: usage[k],
                mapped_at_creation: false,
            })
        };
        let fit = |b: Option<wgpu::Buffer>, k: usize| match b {
            Some(b) if b.size() >= need[k] => b,
            _ => make(k),
        };
        let bufs = match kept {
            Some(b) => Buffers {
                uni: fit(Some(b.uni), 0),
                frag: fit(Some(b.frag), 1),
                out: fit(Some(b.out), 2),
                tmp: fit(Some(b.tmp), 3),
                light: fit(Some(b.light), 4),
                staging: b.staging,
                scratch: b.scratch,
                light_scratch: b.light_scratch,
            },
            None => Buffers {
                uni: make(0),
                frag: make(1),
                out: make(2),
                tmp: make(3),
                light: make(4),
                staging: Mutex::new(None),
                scratch: Vec::new(),
                light_scratch: Mutex::new((Vec::new(), Vec::new())),
            },
        };
        let mut enc = device.create_command_encoder(&Default::default());
        for (b, bytes) in [
            (&bufs.out, need[2]),
            (&bufs.tmp, need[3]),
            (&bufs.light, need[4]),
        ] {
            enc.clear_buffer(b, 0, Some(bytes));
        }
        // Submitted now: the writes queued after it (light samples, host steps) land after
        // the clear.
        self.ctx.queue.submit([enc.finish()]);
        self.ctx
            .queue
            .write_buffer(&bufs.uni, 0, bytemuck::cast_slice(uniforms));
        bufs
    }

    /// Keeps `bufs` for the next batch, unless its device buffers hold more than
    /// [`KEEP_BYTES`] (a material keeps what its batches need, not a scene's worth of
    /// memory per material).
    pub(super) fn keep_buffers(&self, bufs: Buffers) {
        let bytes: u64 = [&bufs.uni, &bufs.frag, &bufs.out, &bufs.tmp, &bufs.light]
            .iter()
            .map(|b| b.size())
            .sum();
        if bytes <= KEEP_BYTES
            && let Ok(mut p) = self.pool.lock()
        {
            p.push(bufs);
        }
    }

    /// Copies column ranges `(first column, columns)` of `src` (columns of `n` floats) into
    /// `bufs`' staging buffer, maps it and hands `read` the floats (the ranges one after
    /// the other).
    fn read_back<T>(
        &self,
        bufs: &Buffers,
        src: &wgpu::Buffer,
        ranges: &[(usize, usize)],
        n: usize,
        read: impl FnOnce(&[f32]) -> T,
    ) -> Result<T, GpuError> {
        let total: usize = ranges.iter().map(|r| r.1 * n).sum();
        if total == 0 {
            return Ok(read(&[]));
        }
        let bytes = (total * 4) as u64;
        let mut slot = bufs.staging.lock().map_err(gpu_err)?;
        let staging = match slot.take() {
            Some(b) if b.size() >= bytes => b,
            _ => self.device().create_buffer(&wgpu::BufferDescriptor {
                label: Some("sn_readback"),
                size: bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        };
        let mut enc = self.device().create_command_encoder(&Default::default());
        let mut at = 0u64;
        for &(c, w) in ranges {
            let len = (w * n * 4) as u64;
            if len > 0 {
                enc.copy_buffer_to_buffer(src, (c * n * 4) as u64, &staging, at, len);
            }
            at += len;
        }
        self.ctx.queue.submit([enc.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging
            .slice(..bytes)
            .map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        self.wait()?;
        rx.recv().map_err(gpu_err)?.map_err(gpu_err)?;
        let view = staging.slice(..bytes).get_mapped_range().map_err(gpu_err)?;
        let r = read(bytemuck::cast_slice(&view));
        drop(view);
        staging.unmap();
        *slot = Some(staging);
        Ok(r)
    }

    /// Copies column ranges `(first column, columns)` of `src` (columns of `n` floats) back
    /// to the host: one vector per range.
    pub(super) fn read_columns(
        &self,
        bufs: &Buffers,
        src: &wgpu::Buffer,
        ranges: &[(usize, usize)],
        n: usize,
    ) -> Result<Vec<Vec<f32>>, GpuError> {
        self.read_back(bufs, src, ranges, n, |all| {
            let mut out = Vec::with_capacity(ranges.len());
            let mut at = 0;
            for &(_, w) in ranges {
                out.push(all.get(at..at + w * n).unwrap_or_default().to_vec());
                at += w * n;
            }
            out
        })
    }

    /// Reads `sn_out` (`w` columns of `n`) straight into `out` in the packets' layout, as
    /// fragments `base .. base + n` of the call, with the output guard (non-finite → 0);
    /// returns how many values the guard zeroed.
    pub(super) fn read_outputs(
        &self,
        bufs: &Buffers,
        n: usize,
        base: usize,
        out: &mut [f32],
    ) -> Result<u64, GpuError> {
        let (w, pw) = (self.plan.layout.out_columns, self.width);
        self.read_back(bufs, &bufs.out, &[(0, w)], n, |cols| {
            let mut bad = 0u64;
            for c in 0..w.min(pw) {
                for (i, x) in cols[c * n..(c + 1) * n].iter().enumerate() {
                    let d = &mut out[packed_index(pw, base + i, c)];
                    if x.is_finite() {
                        *d = *x;
                    } else {
                        *d = 0.0;
                        bad += 1;
                    }
                }
            }
            bad
        })
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
