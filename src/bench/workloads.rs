//! The workloads of the benchmarks, shared by `shadenet bench` and the criterion benches in
//! `benches/` (one definition, no copy).
//!
//! B1's fragments lie on the face z = 1 of the box [1, 2]³, which fills the frame:
//! `P = (1 + u, 1 + v, 1)`. Products of numbers ≥ 1 never become denormal (they overflow to
//! +inf, which the guard zeroes and counts), so the timings measure per-node work, not the
//! microcode assists denormal operands cost on x86.

use crate::generate::mult_tree;
use rayon::prelude::*;
use shadenet_graph::ir::{Program, Space};
use shadenet_graph::opt::{Passes, Specialization};
use shadenet_graph::{NodeLibrary, compile_json};
use shadenet_runtime::{Backend, Fragment, FragmentX4, LANES, Material, ShadeCtx, ShadeEnv};
use std::sync::Arc;

/// The frame of B1: 640×480, as in the thesis.
pub const B1_SIZE: (u32, u32) = (640, 480);

/// The fragments of a `w × h` frame on the box face `P = (1 + u, 1 + v, 1)`, row by row.
pub fn tree_fragments(w: u32, h: u32) -> Vec<Fragment> {
    let mut v = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut f = crate::shade::grid_fragment(x, y, w, h);
            f.p = [1.0 + f.uv[0], 1.0 + f.uv[1], 1.0];
            f.i = [
                f.p[0] - crate::shade::EYE[0] as f32,
                f.p[1] - crate::shade::EYE[1] as f32,
                f.p[2] - crate::shade::EYE[2] as f32,
            ];
            v.push(f);
        }
    }
    v
}

/// The fragments in packets of four (the last one padded).
pub fn packets(frags: &[Fragment]) -> Vec<FragmentX4> {
    frags.chunks(LANES).map(FragmentX4::gather).collect()
}

/// The specialization of B1: the defaults with CSE on or off (off keeps every product: the
/// thesis's per-node cost).
pub fn tree_spec(cse: bool) -> Specialization {
    Specialization {
        passes: Passes {
            cse,
            ..Passes::default()
        },
        ..Specialization::default()
    }
}

/// The linked, unoptimized program of the level-`level` multiplication tree in `space`.
pub fn tree_program(level: u32, space: Space) -> Program {
    let net = mult_tree(level, space).expect("levels 1–16").to_string();
    compile_json(&net, &NodeLibrary::standard())
        .expect("the tree links")
        .program
}

/// Compiles a program with a back end (panics on a back-end error: the benchmark programs
/// are known to compile; a JIT falls back to the interpreter by itself).
pub fn compile(
    backend: &dyn Backend,
    program: &Program,
    spec: &Specialization,
) -> Arc<dyn Material> {
    backend
        .compile(program, spec)
        .expect("the back end compiles the program")
}

/// Shades every fragment with one [`Material::shade`] call each, writing the output of the
/// last one to `out`; returns the non-finite count.
pub fn shade_scalar(m: &dyn Material, env: &ShadeEnv, frags: &[Fragment], out: &mut [f32]) -> u64 {
    let mut bad = 0;
    for f in frags {
        let ctx = ShadeCtx {
            frag: *f,
            env,
            mask: u32::MAX,
            scene: None,
        };
        bad += m.shade(&ctx, out) as u64;
    }
    bad
}

/// Shades every packet with one [`Material::shade_x4`] call each (`out`: `width() * 4`
/// floats); returns the non-finite count.
pub fn shade_packets(
    m: &dyn Material,
    env: &ShadeEnv,
    packets: &[FragmentX4],
    out: &mut [f32],
) -> u64 {
    let mut bad = 0;
    for p in packets {
        bad += m.shade_x4(env, u32::MAX, p, LANES, out) as u64;
    }
    bad
}

/// Shades every packet with the native reference of the level-`level` tree; `None` where
/// there is no native reference (not x86-64, or a level above 10).
pub fn shade_native(level: u32, packets: &[FragmentX4], out: &mut [f32]) -> Option<u64> {
    #[cfg(target_arch = "x86_64")]
    {
        let f = super::native::TREES.get(level.checked_sub(1)? as usize)?;
        let mut bad = 0;
        for p in packets {
            bad += f(p, out, LANES) as u64;
        }
        Some(bad)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (level, packets, out);
        None
    }
}

/// How a material is run over a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Entry {
    /// One [`Material::shade`] call per fragment.
    Scalar,
    /// One [`Material::shade_x4`] call per packet of four.
    Batch,
}

/// Shades a frame with `m` on the current rayon pool, in chunks of 64 packets, writing every
/// fragment's output (array of structures, `width()` floats each) to `out`; returns the
/// non-finite count.
pub fn shade_frame(
    m: &dyn Material,
    env: &ShadeEnv,
    packets: &[FragmentX4],
    n: usize,
    entry: Entry,
    out: &mut [f32],
) -> u64 {
    let w = m.width();
    const CHUNK: usize = 64;
    packets
        .par_chunks(CHUNK)
        .zip(out.par_chunks_mut(CHUNK * LANES * w))
        .enumerate()
        .map(|(c, (ps, dst))| {
            let mut soa = vec![0.0f32; w * LANES];
            let mut one = vec![0.0f32; w];
            let mut bad = 0u64;
            for (i, p) in ps.iter().enumerate() {
                let base = (c * CHUNK + i) * LANES;
                let active = n.saturating_sub(base).min(LANES);
                match entry {
                    Entry::Batch => {
                        bad += m.shade_x4(env, u32::MAX, p, active, &mut soa) as u64;
                        for lane in 0..active {
                            for k in 0..w {
                                dst[(i * LANES + lane) * w + k] = soa[k * LANES + lane];
                            }
                        }
                    }
                    Entry::Scalar => {
                        for lane in 0..active {
                            let ctx = ShadeCtx::new(p.lane(lane), env);
                            bad += m.shade(&ctx, &mut one) as u64;
                            dst[(i * LANES + lane) * w..(i * LANES + lane + 1) * w]
                                .copy_from_slice(&one);
                        }
                    }
                }
            }
            bad
        })
        .sum()
}

/// Shades a frame with the native reference on the current rayon pool, writing every
/// fragment's colour to `out` (three floats each); `None` without a native reference.
pub fn native_frame(level: u32, packets: &[FragmentX4], n: usize, out: &mut [f32]) -> Option<u64> {
    shade_native(
        level,
        &packets[..packets.len().min(1)],
        &mut [0.0; 3 * LANES],
    )?;
    const CHUNK: usize = 64;
    Some(
        packets
            .par_chunks(CHUNK)
            .zip(out.par_chunks_mut(CHUNK * LANES * 3))
            .enumerate()
            .map(|(c, (ps, dst))| {
                let mut soa = [0.0f32; 3 * LANES];
                let mut bad = 0u64;
                for (i, p) in ps.iter().enumerate() {
                    let base = (c * CHUNK + i) * LANES;
                    let active = n.saturating_sub(base).min(LANES);
                    #[cfg(target_arch = "x86_64")]
                    {
                        bad += super::native::TREES[level as usize - 1](p, &mut soa, active) as u64;
                    }
                    for lane in 0..active {
                        for k in 0..3 {
                            dst[(i * LANES + lane) * 3 + k] = soa[k * LANES + lane];
                        }
                    }
                }
                bad
            })
            .sum(),
    )
}
