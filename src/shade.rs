//! `shadenet shade`: shading a network over a grid of fragments on a unit plane, without a
//! renderer (the counterpart of OSL's testshade).
//!
//! The plane is z = 0, x and y in [−0.5, 0.5], normal +z, seen from a camera at (0, 0, 1.5)
//! looking at the origin. Pixel (x, y) (row 0 at the top) gets `uv = ((x+½)/W, 1 − (y+½)/H)`,
//! `P = (u − ½, v − ½, 0)`, `dPdu = (1, 0, 0)`, `dPdv = (0, 1, 0)`, ray differentials of one
//! pixel, and `I = P − eye`.

use rayon::prelude::*;
use shadenet_graph::ir::{Program, RAY_CAMERA};
use shadenet_graph::ops::Real;
use shadenet_runtime::{
    BatchResult, Fragment, FragmentX4, Interpreter, LANES, Material, ShadeCtx, ShadeEnv, ShadeOut,
    Transform,
};

/// The eye position of the shade camera.
pub const EYE: [f64; 3] = [0.0, 0.0, 1.5];

/// The fragment of pixel (x, y) of a `w × h` grid.
pub fn grid_fragment(x: u32, y: u32, w: u32, h: u32) -> Fragment {
    let u = (x as f32 + 0.5) / w as f32;
    let v = 1.0 - (y as f32 + 0.5) / h as f32;
    let p = [u - 0.5, v - 0.5, 0.0];
    Fragment {
        p,
        n: [0.0, 0.0, 1.0],
        ng: [0.0, 0.0, 1.0],
        i: [
            p[0] - EYE[0] as f32,
            p[1] - EYE[1] as f32,
            p[2] - EYE[2] as f32,
        ],
        uv: [u, v],
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        dpdx: [1.0 / w as f32, 0.0, 0.0],
        dpdy: [0.0, -1.0 / h as f32, 0.0],
        time: 0.0,
        ray_type: RAY_CAMERA,
        ray_depth: 0,
        seed: y * w + x,
        // No scene: a BSDF sample's ray returns black whatever its direction.
        rand: [0.5; 4],
    }
}

/// The environment of the shade grid: the given lights, the camera at [`EYE`], identity
/// object space.
pub fn grid_env(lights: &[shadenet_graph::nodes::LightDesc]) -> ShadeEnv {
    let mut env = ShadeEnv::with_lights(lights);
    env.camera = Transform::look_at(EYE, [0.0; 3], [0.0, 1.0, 0.0]).unwrap_or(Transform::IDENTITY);
    env
}

/// The result of shading a grid: per pixel, every program output flattened (see
/// [`shadenet_runtime::OutputSlot`]), as f64 whatever the precision used.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Floats per pixel.
    pub stride: usize,
    /// `width * height * stride` values, rows top to bottom.
    pub values: Vec<f64>,
    /// Non-finite values replaced by the output guard.
    pub nonfinite: u64,
}

/// Shades every pixel of a `w × h` grid with the interpreter in precision `F`, on the rayon
/// thread pool, with the components in `mask` active. Fails only if a texture cannot be
/// loaded.
pub fn shade_grid<F: Real>(
    program: &Program,
    env: &ShadeEnv,
    w: u32,
    h: u32,
    mask: u32,
) -> Result<Grid, shadenet_runtime::TextureError> {
    let interp = Interpreter::<F>::new(program)?;
    let stride: usize = interp.slots().iter().map(|s| s.ty.width().max(1)).sum();
    Ok(grid(w, h, stride, |y, row| {
        let mut scratch = Default::default();
        let mut out = ShadeOut {
            values: Vec::new(),
            nonfinite: 0,
        };
        let mut bad = 0u64;
        for (x, dst) in row.chunks_mut(stride).enumerate() {
            let mut ctx = ShadeCtx::new(grid_fragment(x as u32, y, w, h), env);
            ctx.mask = mask;
            interp.shade_with(&ctx, &mut scratch, &mut out);
            bad += out.nonfinite as u64;
            for (d, s) in dst.iter_mut().zip(&out.values) {
                *d = s.to_f64();
            }
        }
        bad
    }))
}

/// The grid loop both shading paths share: rows in parallel on the rayon pool, `row(y,
/// values)` fills one row (`w * stride` floats) and returns its non-finite count.
fn grid(w: u32, h: u32, stride: usize, row: impl Fn(u32, &mut [f64]) -> u64 + Sync) -> Grid {
    let mut values = vec![0.0f64; (w * h) as usize * stride];
    let nonfinite = values
        .par_chunks_mut((w as usize * stride).max(1))
        .enumerate()
        .map(|(y, r)| row(y as u32, r))
        .sum();
    Grid {
        width: w,
        height: h,
        stride,
        values,
        nonfinite,
    }
}

/// Shades every pixel of a `w × h` grid with a compiled material on the rayon thread pool,
/// with the components in `mask` active: one [`Material::shade`] call per fragment, or with
/// `batch` one [`Material::shade_x4`] call per four fragments of a row.
pub fn shade_grid_with(
    material: &dyn Material,
    env: &ShadeEnv,
    w: u32,
    h: u32,
    mask: u32,
    batch: bool,
) -> Grid {
    let stride = material.width();
    grid(w, h, stride, |y, row| {
        let mut bad = 0u64;
        let frags: Vec<Fragment> = (0..w).map(|x| grid_fragment(x, y, w, h)).collect();
        if batch {
            let mut soa = vec![0.0f32; stride * LANES];
            for (chunk, dst) in frags.chunks(LANES).zip(row.chunks_mut(stride * LANES)) {
                let packet = FragmentX4::gather(chunk);
                bad += material.shade_x4(env, mask, &packet, chunk.len(), &mut soa) as u64;
                for (lane, px) in dst.chunks_mut(stride).enumerate() {
                    for (k, d) in px.iter_mut().enumerate() {
                        *d = soa[k * LANES + lane] as f64;
                    }
                }
            }
        } else {
            let mut out = vec![0.0f32; stride];
            for (f, dst) in frags.iter().zip(row.chunks_mut(stride)) {
                let ctx = ShadeCtx {
                    frag: *f,
                    env,
                    mask,
                    scene: None,
                };
                bad += material.shade(&ctx, &mut out) as u64;
                for (d, s) in dst.iter_mut().zip(&out) {
                    *d = *s as f64;
                }
            }
        }
        bad
    })
}

/// Shades every pixel of a `w × h` grid with one [`Material::shade_many`] call (the batch
/// entry the GPU implements; no scene), with the components in `mask` active. Returns the
/// grid and the call's result (non-finite count, where the time went).
pub fn shade_grid_many(
    material: &dyn Material,
    env: &ShadeEnv,
    w: u32,
    h: u32,
    mask: u32,
) -> (Grid, BatchResult) {
    let stride = material.width();
    let frags: Vec<Fragment> = (0..h)
        .flat_map(|y| (0..w).map(move |x| grid_fragment(x, y, w, h)))
        .collect();
    let mut out = vec![0.0f32; frags.len() * stride];
    let result = material.shade_many(env, mask, None, &frags, &mut out);
    let grid = Grid {
        width: w,
        height: h,
        stride,
        values: out.iter().map(|v| *v as f64).collect(),
        nonfinite: result.nonfinite,
    };
    (grid, result)
}
