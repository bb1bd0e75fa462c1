//! `shadenet shade`: shading a network over a grid of fragments on a unit plane, without a
//! renderer (the counterpart of OSL's testshade).
//!
//! The plane is z = 0, x and y in [−0.5, 0.5], normal +z, seen from a camera at (0, 0, 1.5)
//! looking at the origin. Pixel (x, y) (row 0 at the top) gets `uv = ((x+½)/W, 1 − (y+½)/H)`,
//! `P = (u − ½, v − ½, 0)`, `dPdu = (1, 0, 0)`, `dPdv = (0, 1, 0)`, ray differentials of one
//! pixel, and `I = P − eye`.
//!
//! It also shades any list of fragments ([`shade_fragments`], what the Python package's
//! `Material.shade` runs) and names what was shaded: [`output_layers`] is the one naming of
//! a material's outputs and components as layers (`color`, `color.diffuse`) and channels,
//! used by `shade -o x.exr` ([`exr_channels`]) and by the Python package.

use rayon::prelude::*;
use shadenet_graph::ir::{Program, RAY_CAMERA};
use shadenet_graph::ops::Real;
use shadenet_runtime::messages::{self, Messages};
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
        // No scene: a BSDF sample's ray returns black whatever its direction, so these only
        // decide which direction is drawn — spread over [0, 1) as a renderer's sampler's
        // are (the same 0.5 everywhere drew the same angle for every fragment: exactly π
        // for the GGX samples, whose argument reduction is the slow exact path).
        rand: [0, 1, 2, 3].map(|k| grid_rand(x, y, k)),
    }
}

/// A number in [0, 1) from a hash of the fragment's position and the dimension `k`.
fn grid_rand(x: u32, y: u32, k: u32) -> f32 {
    let h = shadenet_tracer::render::hash3(x, y, k);
    // The top 24 bits: exactly representable, below 1.
    (h >> 8) as f32 / (1u32 << 24) as f32
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
    /// What the shader printed (`printf`, `warning`, `error`), in pixel order.
    pub messages: Messages,
}

/// Two adjacent rows' (or runs') non-finite counts summed and their messages joined in
/// order: what the parallel shading loops reduce with (rayon keeps the order of an indexed
/// iterator's items), so a frame allocates nothing for rows that print nothing.
fn join((bad, mut all): (u64, Messages), (more, m): (u64, Messages)) -> (u64, Messages) {
    all.append(m);
    (bad + more, all)
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
    let (nonfinite, messages) = values
        .par_chunks_mut((w as usize * stride).max(1))
        .enumerate()
        .map(|(y, row)| {
            let mut scratch = Default::default();
            let mut out = ShadeOut::default();
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
            (bad, messages::take())
        })
        .reduce(Default::default, join);
    Ok(Grid {
        width: w,
        height: h,
        stride,
        values: GridValues::Pixels(values),
        nonfinite,
        messages,
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
            for (k, r) in packet.rand.iter_mut().enumerate() {
                *r = std::array::from_fn(|lane| grid_rand(x_of(p, lane), y, k as u32));
            }
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
    let (nonfinite, messages) = shade_grid_into(material, env, (w, h), mask, batch, &mut data);
    Grid {
        width: w,
        height: h,
        stride: material.width(),
        values: GridValues::Packed {
            data,
            segment: w as usize,
        },
        nonfinite,
        messages,
    }
}

/// [`shade_grid_with`] into a buffer the caller keeps from frame to frame (resized to the
/// grid's packed size; no allocation once it is large enough, as a renderer's frame buffer
/// or OSL's testshade output after its first frame). Returns the non-finite count and what
/// the shader printed, in pixel order.
pub fn shade_grid_into(
    material: &dyn Material,
    env: &ShadeEnv,
    (w, h): (u32, u32),
    mask: u32,
    batch: bool,
    data: &mut Vec<f32>,
) -> (u64, Messages) {
    let stride = material.width();
    let row_len = packed_len(stride, w as usize);
    data.resize(row_len * h as usize, 0.0);
    data.par_chunks_mut(row_len.max(1))
        .enumerate()
        .map_init(RowPackets::default, |rows, (y, dst)| {
            let y = y as u32;
            if batch {
                let frags = rows.row(y, w, h);
                let bad = material.shade_many(env, mask, None, frags, dst).nonfinite;
                return (bad, messages::take());
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
            (bad, messages::take())
        })
        .reduce(Default::default, join)
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
    let messages = messages::take();
    let grid = Grid {
        width: w,
        height: h,
        stride,
        values: GridValues::Packed {
            data,
            segment: frags.len().max(1),
        },
        nonfinite: result.nonfinite,
        messages,
    };
    (grid, result)
}

/// Shades a list of fragments with a compiled material on the rayon thread pool, with the
/// components in `mask` active: one [`Material::shade`] call per fragment, or with `batch`
/// one [`Material::shade_many`] call per run of [`FRAGMENTS_PER_BATCH`] fragments (`all`:
/// one call for every fragment, as the GPU wants). No scene: a BSDF sample's ray returns
/// black. The result is a grid one fragment high, packed as one segment.
pub fn shade_fragments(
    material: &dyn Material,
    env: &ShadeEnv,
    frags: &[Fragment],
    mask: u32,
    batch: BatchMode,
) -> Grid {
    let stride = material.width();
    let n = frags.len();
    let mut data = vec![0.0f32; packed_len(stride, n)];
    let per_packet = (stride * LANES).max(1);
    let (nonfinite, messages) = match batch {
        BatchMode::All => {
            let all = Fragments::from_slice(frags);
            let r = material.shade_many(env, mask, None, &all, &mut data);
            (r.nonfinite, messages::take())
        }
        BatchMode::Batches => data
            .par_chunks_mut(per_packet * FRAGMENTS_PER_BATCH / LANES)
            .zip(frags.par_chunks(FRAGMENTS_PER_BATCH))
            .map(|(dst, chunk)| {
                let chunk = Fragments::from_slice(chunk);
                let bad = material.shade_many(env, mask, None, &chunk, dst).nonfinite;
                (bad, messages::take())
            })
            .reduce(Default::default, join),
        BatchMode::Single => data
            .par_chunks_mut(per_packet)
            .zip(frags.par_chunks(LANES))
            .map(|(dst, packet)| {
                let mut one = vec![0.0f32; stride];
                let mut bad = 0u64;
                for (lane, frag) in packet.iter().enumerate() {
                    let ctx = ShadeCtx {
                        frag: *frag,
                        env,
                        mask,
                        scene: None,
                    };
                    bad += material.shade(&ctx, &mut one) as u64;
                    for (k, v) in one.iter().enumerate() {
                        dst[packed_index(stride, lane, k)] = *v;
                    }
                }
                (bad, messages::take())
            })
            .reduce(Default::default, join),
    };
    Grid {
        width: n as u32,
        height: 1,
        stride,
        values: GridValues::Packed {
            data,
            segment: n.max(1),
        },
        nonfinite,
        messages,
    }
}

/// Fragments per [`Material::shade_many`] call of [`shade_fragments`] with
/// [`BatchMode::Batches`] (a multiple of the packet width).
pub const FRAGMENTS_PER_BATCH: usize = 64 * LANES;

/// How [`shade_fragments`] calls the material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BatchMode {
    /// [`Material::shade`], one fragment per call (the interpreter, the JIT's scalar entry).
    Single,
    /// [`Material::shade_many`] over runs of [`FRAGMENTS_PER_BATCH`] fragments, in
    /// parallel (the JIT's batch entry).
    Batches,
    /// One [`Material::shade_many`] call for every fragment (the GPU: one dispatch).
    All,
}

/// The output layout every back end writes: (name, component, type, offset) per slot.
pub type Slots = Vec<(String, Option<u8>, shadenet_graph::Type, usize)>;

/// The slots of `program`'s outputs ([`shadenet_runtime::output_layout`]).
pub fn output_slots(program: &Program) -> Slots {
    shadenet_runtime::output_layout(program)
        .0
        .into_iter()
        .map(|s| (s.name, s.component, s.ty, s.offset))
        .collect()
}

/// Channel `c` of the slots `pred` picks, summed per fragment, as f32 (a slot narrower than
/// `c + 1` gives its last channel).
pub fn channel(
    grid: &Grid,
    slots: &Slots,
    pred: &dyn Fn(&str, Option<u8>) -> bool,
    c: usize,
) -> Vec<f32> {
    let n = (grid.width * grid.height) as usize;
    let mut out = vec![0.0f32; n];
    for (name, comp, ty, off) in slots {
        if !pred(name, *comp) {
            continue;
        }
        let w = ty.width().max(1);
        let ci = c.min(w - 1);
        for (o, x) in out.iter_mut().zip(grid.component(off + ci)) {
            *o += x as f32;
        }
    }
    out
}

/// One layer of a shaded grid: an output's total (every part of it summed) or one of its
/// render components, named `output` or `output.component`.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputLayer {
    /// `output` or `output.component`.
    pub name: String,
    /// The channel names: `X Y` (2 floats), `R G B` (3), `R G B A` (colour4), `X Y Z W`
    /// (other 4-float types), `Y` (1).
    pub channels: Vec<&'static str>,
    /// Per channel, one f32 per fragment.
    pub data: Vec<Vec<f32>>,
}

/// The channel names of an output of type `ty` (see [`OutputLayer::channels`]).
pub fn channel_names(ty: shadenet_graph::Type) -> &'static [&'static str] {
    match ty.width() {
        2 => &["X", "Y"],
        3 => &["R", "G", "B"],
        4 if ty.is_color() => &["R", "G", "B", "A"],
        4 => &["X", "Y", "Z", "W"],
        _ => &["Y"],
    }
}

/// The layers of a grid shaded with `program`: per output its total, then each of its
/// components, in the program's output order.
pub fn output_layers(program: &Program, grid: &Grid) -> Vec<OutputLayer> {
    let slots = output_slots(program);
    let mut out = Vec::new();
    for name in program.output_names() {
        let Some(ty) = slots.iter().find(|s| s.0 == name).map(|s| s.2) else {
            continue;
        };
        let suffixes = channel_names(ty);
        let mut layers: Vec<(String, Option<Option<u8>>)> = vec![(name.to_string(), None)];
        for (sn, comp, _, _) in &slots {
            if let Some(k) = comp
                && sn == name
            {
                layers.push((
                    format!("{name}.{}", program.components[*k as usize]),
                    Some(*comp),
                ));
            }
        }
        for (layer, only) in layers {
            let pred = |n: &str, c: Option<u8>| n == name && only.is_none_or(|o| o == c);
            out.push(OutputLayer {
                name: layer,
                channels: suffixes.to_vec(),
                data: (0..suffixes.len())
                    .map(|ci| channel(grid, &slots, &pred, ci))
                    .collect(),
            });
        }
    }
    out
}

/// The EXR channels of a grid shaded with `program` (`shadenet shade -o x.exr`): every
/// [`output_layers`] layer's channels, named `layer.channel`.
pub fn exr_channels(program: &Program, grid: &Grid) -> Vec<(String, Vec<f32>)> {
    output_layers(program, grid)
        .into_iter()
        .flat_map(|l| {
            let name = l.name;
            l.channels
                .into_iter()
                .zip(l.data)
                .map(move |(c, d)| (format!("{name}.{c}"), d))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Shading the grid's fragments as a list gives the grid's layers bit for bit, in every
    /// batch mode, with the interpreter and the JIT (scalar and batch entries); 300
    /// fragments: more than one batch, the last packet partial.
    #[test]
    fn shading_fragments_equals_shading_the_grid() {
        use shadenet_runtime::Backend;
        let compiled = crate::load_network(std::path::Path::new("examples/networks/marble.json"))
            .expect("marble.json");
        let program = compiled.program;
        let env = grid_env(&[crate::lights::parse_light(crate::lights::DEFAULT_LIGHT, 0).unwrap()]);
        let (w, h) = (20u32, 15u32);
        let frags: Vec<Fragment> = (0..h)
            .flat_map(|y| (0..w).map(move |x| grid_fragment(x, y, w, h)))
            .collect();
        let spec = shadenet_graph::opt::Specialization::default();
        let backends: [(&dyn Backend, bool); 2] = [
            (&shadenet_runtime::InterpBackend, false),
            (&shadenet_jit::JitBackend::new(), true),
        ];
        for (backend, batch) in backends {
            let material = backend.compile(&program, &spec).unwrap();
            let want = output_layers(
                &program,
                &shade_grid_with(&*material, &env, w, h, u32::MAX, batch),
            );
            for mode in [BatchMode::Single, BatchMode::Batches, BatchMode::All] {
                let got = shade_fragments(&*material, &env, &frags, u32::MAX, mode);
                let got = output_layers(&program, &got);
                assert!(!want.is_empty());
                assert_eq!(got.len(), want.len());
                for (g, x) in got.iter().zip(&want) {
                    assert_eq!((&g.name, &g.channels), (&x.name, &x.channels));
                    for (a, b) in g.data.iter().zip(&x.data) {
                        let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                        assert_eq!(bits(a), bits(b), "{} {mode:?} {}", backend.name(), g.name);
                    }
                }
            }
        }
    }

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
                messages: Messages::default(),
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
