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
    BatchResult, Fragment, Fragments, Interpreter, LANES, Material, ShadeCtx, ShadeEnv, ShadeOut,
    Transform, packed_index, packed_len,
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

/// The values of a shaded grid, in the layout the shading path produced them.
#[derive(Clone, Debug)]
pub enum GridValues {
    /// f64, pixel after pixel, every output float of a pixel together (the interpreter).
    Pixels(Vec<f64>),
    /// f32 in the packets' layout of `Material::shade_many` (`shadenet_runtime::packets`),
    /// segment after segment: every `segment` consecutive pixels (a row, or the whole
    /// grid) are packed on their own, `packed_len(stride, segment)` floats each.
    Packed {
        /// The floats.
        data: Vec<f32>,
        /// Pixels per packed segment.
        segment: usize,
    },
}

/// The result of shading a grid: per pixel, every program output flattened (see
/// [`shadenet_runtime::OutputSlot`]); [`Grid::get`] reads a value whatever the layout.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Floats per pixel.
    pub stride: usize,
    /// The values, rows top to bottom.
    pub values: GridValues,
    /// Non-finite values replaced by the output guard.
    pub nonfinite: u64,
}

impl Grid {
    /// Float `k` of pixel `p` (pixels row after row, top first).
    pub fn get(&self, p: usize, k: usize) -> f64 {
        match &self.values {
            GridValues::Pixels(v) => v[p * self.stride + k],
            GridValues::Packed { data, segment } => {
                let base = (p / segment) * packed_len(self.stride, *segment);
                data[base + packed_index(self.stride, p % segment, k)] as f64
            }
        }
    }

    /// Float `k` of every pixel, in pixel order (a channel of an image), as f64.
    pub fn component(&self, k: usize) -> Vec<f64> {
        let n = (self.width * self.height) as usize;
        match &self.values {
            GridValues::Pixels(v) => (0..n).map(|p| v[p * self.stride + k]).collect(),
            GridValues::Packed { data, segment } => {
                let seg_len = packed_len(self.stride, *segment);
                let mut out = Vec::with_capacity(n);
                for seg in data.chunks(seg_len.max(1)) {
                    let start = out.len();
                    for packet in seg.chunks(self.stride * LANES) {
                        out.extend(packet[k * LANES..(k + 1) * LANES].iter().map(|x| *x as f64));
                    }
                    // The last packet's padding lanes are not pixels.
                    out.truncate(start + *segment);
                }
                out.truncate(n);
                out
            }
        }
    }

    /// Every value, pixel after pixel (`stride` floats each), as f64.
    pub fn pixel_values(&self) -> Vec<f64> {
        match &self.values {
            GridValues::Pixels(v) => v.clone(),
            GridValues::Packed { .. } => {
                let n = (self.width * self.height) as usize;
                (0..n * self.stride)
                    .map(|j| self.get(j / self.stride.max(1), j % self.stride.max(1)))
                    .collect()
            }
        }
    }
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
    let mut values = vec![0.0f64; (w * h) as usize * stride];
    let nonfinite = values
        .par_chunks_mut((w as usize * stride).max(1))
        .enumerate()
        .map(|(y, row)| {
            let mut scratch = Default::default();
            let mut out = ShadeOut {
                values: Vec::new(),
                nonfinite: 0,
            };
            let mut bad = 0u64;
            for (x, dst) in row.chunks_mut(stride.max(1)).enumerate() {
                let mut ctx = ShadeCtx::new(grid_fragment(x as u32, y as u32, w, h), env);
                ctx.mask = mask;
                interp.shade_with(&ctx, &mut scratch, &mut out);
                bad += out.nonfinite as u64;
                for (d, s) in dst.iter_mut().zip(&out.values) {
                    *d = s.to_f64();
                }
            }
            bad
        })
        .sum();
    Ok(Grid {
        width: w,
        height: h,
        stride,
        values: GridValues::Pixels(values),
        nonfinite,
    })
}

/// One row of the grid as packets, built in place: the first call writes every field, the
/// next ones only what changes from row to row (`P.y`, `I.y`, `v`, the seed), with the
/// same arithmetic as [`grid_fragment`]. The lanes past the row's end repeat its last
/// pixel.
#[derive(Default)]
struct RowPackets {
    frags: Fragments,
    /// The grid size the packets were fully written for.
    ready: Option<(u32, u32)>,
}

impl RowPackets {
    fn row(&mut self, y: u32, w: u32, h: u32) -> &Fragments {
        let x_of = |p: usize, lane: usize| (p * LANES + lane).min(w as usize - 1) as u32;
        if self.ready != Some((w, h)) {
            self.frags.fill(w as usize, |p, packet| {
                for lane in 0..LANES {
                    packet.set_lane(lane, &grid_fragment(x_of(p, lane), y, w, h));
                }
            });
            self.ready = Some((w, h));
            return &self.frags;
        }
        let v = 1.0 - (y as f32 + 0.5) / h as f32;
        let py = v - 0.5;
        let iy = py - EYE[1] as f32;
        for (p, packet) in self.frags.packets_mut().iter_mut().enumerate() {
            packet.p[1] = [py; LANES];
            packet.i[1] = [iy; LANES];
            packet.uv[1] = [v; LANES];
            packet.seed = std::array::from_fn(|lane| y * w + x_of(p, lane));
        }
        &self.frags
    }
}

/// Shades every pixel of a `w × h` grid with a compiled material on the rayon thread pool,
/// with the components in `mask` active: one [`Material::shade`] call per fragment, or with
/// `batch` one [`Material::shade_many`] call per row (the row built straight into packets;
/// the JIT shades it in one call of its batch entry). The result is packed row by row.
pub fn shade_grid_with(
    material: &dyn Material,
    env: &ShadeEnv,
    w: u32,
    h: u32,
    mask: u32,
    batch: bool,
) -> Grid {
    let mut data = Vec::new();
    let nonfinite = shade_grid_into(material, env, (w, h), mask, batch, &mut data);
    Grid {
        width: w,
        height: h,
        stride: material.width(),
        values: GridValues::Packed {
            data,
            segment: w as usize,
        },
        nonfinite,
    }
}

/// [`shade_grid_with`] into a buffer the caller keeps from frame to frame (resized to the
/// grid's packed size; no allocation once it is large enough, as a renderer's frame buffer
/// or OSL's testshade output after its first frame). Returns the non-finite count.
pub fn shade_grid_into(
    material: &dyn Material,
    env: &ShadeEnv,
    (w, h): (u32, u32),
    mask: u32,
    batch: bool,
    data: &mut Vec<f32>,
) -> u64 {
    let stride = material.width();
    let row_len = packed_len(stride, w as usize);
    data.resize(row_len * h as usize, 0.0);
    data.par_chunks_mut(row_len.max(1))
        .enumerate()
        .map_init(RowPackets::default, |rows, (y, dst)| {
            let y = y as u32;
            if batch {
                let frags = rows.row(y, w, h);
                return material.shade_many(env, mask, None, frags, dst).nonfinite;
            }
            let mut one = vec![0.0f32; stride];
            let mut bad = 0u64;
            for x in 0..w {
                let ctx = ShadeCtx {
                    frag: grid_fragment(x, y, w, h),
                    env,
                    mask,
                    scene: None,
                };
                bad += material.shade(&ctx, &mut one) as u64;
                for (k, v) in one.iter().enumerate() {
                    dst[packed_index(stride, x as usize, k)] = *v;
                }
            }
            bad
        })
        .sum()
}

/// Shades every pixel of a `w × h` grid with one [`Material::shade_many`] call (the batch
/// entry the GPU implements; no scene), with the components in `mask` active. Returns the
/// grid (packed as one segment) and the call's result (non-finite count, where the time
/// went).
pub fn shade_grid_many(
    material: &dyn Material,
    env: &ShadeEnv,
    w: u32,
    h: u32,
    mask: u32,
) -> (Grid, BatchResult) {
    let stride = material.width();
    let frags: Fragments = (0..h)
        .flat_map(|y| (0..w).map(move |x| grid_fragment(x, y, w, h)))
        .collect();
    let mut data = vec![0.0f32; packed_len(stride, frags.len())];
    let result = material.shade_many(env, mask, None, &frags, &mut data);
    let grid = Grid {
        width: w,
        height: h,
        stride,
        values: GridValues::Packed {
            data,
            segment: frags.len().max(1),
        },
        nonfinite: result.nonfinite,
    };
    (grid, result)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The row packets equal the grid's fragments, lane for lane, on the first row built
    /// and on every later row updated in place (padding lanes: the row's last pixel).
    #[test]
    fn row_packets_are_the_grid_fragments() {
        let (w, h) = (7u32, 5u32);
        let mut rows = RowPackets::default();
        for y in [0, 3, 4, 1] {
            let frags = rows.row(y, w, h);
            assert_eq!(frags.len(), w as usize);
            for (p, packet) in frags.packets().iter().enumerate() {
                for lane in 0..LANES {
                    let x = (p * LANES + lane).min(w as usize - 1) as u32;
                    assert_eq!(packet.lane(lane), grid_fragment(x, y, w, h), "({x}, {y})");
                }
            }
        }
    }

    /// Every layout reads back the same values: per pixel ([`Grid::get`]), per channel
    /// ([`Grid::component`]) and all at once ([`Grid::pixel_values`]), for rows that end
    /// inside a packet and for one segment over the whole grid.
    #[test]
    fn packed_grids_read_back_in_pixel_order() {
        let (w, h, stride) = (5u32, 3u32, 2usize);
        let value = |p: usize, k: usize| (p * 10 + k) as f64;
        let n = (w * h) as usize;
        for segment in [w as usize, n] {
            let mut data = vec![f32::NAN; packed_len(stride, segment) * (n / segment)];
            for p in 0..n {
                for k in 0..stride {
                    let at = (p / segment) * packed_len(stride, segment)
                        + packed_index(stride, p % segment, k);
                    data[at] = value(p, k) as f32;
                }
            }
            let g = Grid {
                width: w,
                height: h,
                stride,
                values: GridValues::Packed { data, segment },
                nonfinite: 0,
            };
            let want: Vec<f64> = (0..n * stride)
                .map(|j| value(j / stride, j % stride))
                .collect();
            assert_eq!(g.pixel_values(), want, "segment {segment}");
            for k in 0..stride {
                let col: Vec<f64> = (0..n).map(|p| value(p, k)).collect();
                assert_eq!(g.component(k), col, "segment {segment}, float {k}");
                assert_eq!(g.get(7, k), value(7, k));
            }
        }
    }
}
