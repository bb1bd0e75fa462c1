//! The film stage: where a pixel's floats live (components, alpha, override passes), how a
//! shading call's outputs are added to a camera sample, and the composition of the
//! accumulated pixels into the film's layers. It must not trace or shade.

use super::compile::Specialized;
use super::setup::Renderer;
use crate::film::{Film, Layer, Window};
use crate::passes::{OverrideKind, PassKind};

/// Where the per-pixel floats live.
pub(super) struct Layout {
    /// Scene components: the first `3·ncomp` floats of a pixel are the beauty's parts,
    /// then 3 untagged, 1 alpha, then `3·ncomp` parts from outside the beauty.
    pub(super) ncomp: usize,
    pub(super) overrides: Vec<(OverrideKind, usize)>,
    /// Whether an override pass reads uv or tangents.
    pub(super) overrides_need_uv: bool,
    pub(super) stride: usize,
}

pub(super) struct TileOut {
    pub(super) values: Vec<f32>,
}

/// Adds a material's output parts (`values`: one shading call's outputs) to a sample.
pub(super) fn add_parts(sp: &Specialized, values: &[f32], layout: &Layout, sample: &mut [f32]) {
    for part in &sp.parts {
        let base = match (part.beauty, part.comp) {
            (true, Some(k)) => k * 3,
            (true, None) => layout.ncomp * 3,
            (false, Some(k)) => layout.ncomp * 3 + 4 + k * 3,
            (false, None) => continue,
        };
        for c in 0..part.width.min(3) {
            sample[base + c] += values[part.offset + c];
        }
    }
}

/// An override rule's value goes to the beauty (untagged).
pub(super) fn add_override_beauty(v: [f32; 3], layout: &Layout, sample: &mut [f32]) {
    for c in 0..3 {
        sample[layout.ncomp * 3 + c] += v[c.min(v.len() - 1)];
    }
}

/// An override pass's channels go to its place in the sample.
pub(super) fn put_override_pass(kind: OverrideKind, off: usize, v: [f32; 3], sample: &mut [f32]) {
    let nc = kind.channels().len();
    sample[off..off + nc].copy_from_slice(&v[..nc]);
}

/// The value of an override shader from its outputs: its channels (up to 3 floats), a
/// one-channel value (depth, occlusion) repeated in all three so that an override rule
/// shows it as grey in the beauty.
pub(super) fn override_channels(kind: OverrideKind, values: &[f32]) -> [f32; 3] {
    let mut v = [0.0f32; 3];
    for (d, s) in v.iter_mut().zip(values) {
        *d = *s;
    }
    if kind.channels().len() == 1 {
        v = [v[0]; 3];
    }
    v
}

impl Renderer {
    pub(super) fn layout(&self) -> Layout {
        let ncomp = self.components.names.len();
        // Beauty components (3 each), untagged (3), alpha (1), components from outside the
        // beauty (3 each), then each override pass's channels.
        let mut offset = ncomp * 6 + 4;
        let mut overrides = Vec::new();
        for p in &self.scene.settings.passes {
            if let PassKind::Override(o) = p.kind {
                overrides.push((o, offset));
                offset += o.channels().len();
            }
        }
        let overrides_need_uv = overrides.iter().any(|(o, _)| self.override_needs_uv(*o));
        Layout {
            ncomp,
            overrides,
            overrides_need_uv,
            stride: offset,
        }
    }

    /// The film's layers from the accumulated pixels of `window` (row-major, `stride`
    /// floats each).
    pub(super) fn compose(&self, acc: &[f32], layout: &Layout, window: Window) -> Film {
        let n = window.pixels();
        let px = |i: usize| &acc[i * layout.stride..(i + 1) * layout.stride];
        let mut layers = Vec::new();
        // beauty = every component + untagged values; A = coverage.
        let mut beauty = vec![0.0f32; n * 4];
        for i in 0..n {
            let v = px(i);
            for c in 0..3 {
                let mut s = 0.0f32;
                for k in 0..layout.ncomp {
                    s += v[k * 3 + c];
                }
                s += v[layout.ncomp * 3 + c];
                beauty[i * 4 + c] = s;
            }
            beauty[i * 4 + 3] = v[layout.ncomp * 3 + 3];
        }
        layers.push(Layer::new("beauty", &["R", "G", "B", "A"], beauty));
        for p in &self.scene.settings.passes {
            match &p.kind {
                PassKind::Components(names) => {
                    let ks: Vec<usize> = names
                        .iter()
                        .filter_map(|nm| self.components.index(nm))
                        .collect();
                    let extra = layout.ncomp * 3 + 4;
                    let mut data = vec![0.0f32; n * 3];
                    for i in 0..n {
                        let v = px(i);
                        for c in 0..3 {
                            let mut s = 0.0f32;
                            for &k in &ks {
                                s += v[k * 3 + c] + v[extra + k * 3 + c];
                            }
                            data[i * 3 + c] = s;
                        }
                    }
                    layers.push(Layer::new(&p.name, &["R", "G", "B"], data));
                }
                PassKind::Override(o) => {
                    let off = layout
                        .overrides
                        .iter()
                        .find(|(k, _)| k == o)
                        .map_or(0, |x| x.1);
                    let nc = o.channels().len();
                    let mut data = vec![0.0f32; n * nc];
                    for i in 0..n {
                        data[i * nc..(i + 1) * nc].copy_from_slice(&px(i)[off..off + nc]);
                    }
                    layers.push(Layer::new(&p.name, o.channels(), data));
                }
            }
        }
        Film {
            width: window.width(),
            height: window.height(),
            window,
            frame: (self.scene.camera.width, self.scene.camera.height),
            layers,
        }
    }
}

/// The pixels of consecutive camera samples (`spp` per pixel, `stride` floats each, in
/// pixel order): each pixel's samples added in sample order, then scaled by `1/spp`.
pub(super) fn accumulate(samples: &[f32], spp: u32, stride: usize) -> Vec<f32> {
    let inv = 1.0 / spp as f32;
    let per_pixel = spp as usize * stride;
    let mut values = vec![0.0f32; samples.len() / per_pixel.max(1) * stride];
    for (dst, src) in values
        .chunks_exact_mut(stride)
        .zip(samples.chunks_exact(per_pixel))
    {
        for sample in src.chunks_exact(stride) {
            for (d, v) in dst.iter_mut().zip(sample) {
                *d += *v;
            }
        }
        dst.iter_mut().for_each(|v| *v *= inv);
    }
    values
}
